// The WebAssembly reader (npm/patchvis.wasm through npm/patchvis.mjs) against every
// conformance vector (tests/conformance): each valid file opens with the dump's counts and
// answers every `query` line of its dump (inside flag, band, answering shells, both shells'
// views, the visible patches) with the triangle ranges its `patch` lines give, merged; each
// invalid file is refused with the reference reader's exact message. Every `query` line is
// asked, whatever its band: eyes nearer the model, at the sampling distance and beyond it
// (version 6's far band). Dump lines this test does not know are skipped. The module is a full
// reader (Cargo feature `wasm` includes `shells`), so the dumps' `far-query` lines, a far-only
// reader's answers, are not its answers. Run by tests/wasm/run.sh (CI) on the source tree's
// module, and by tests/npm/run.sh on an installed package's: PATCHVIS_MODULE names the module
// file to test (default npm/patchvis.mjs), which loads the patchvis.wasm beside it. Needs
// Node 18+.
import { readFileSync, readdirSync } from "node:fs";
import { join, dirname } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

const root = join(dirname(fileURLToPath(import.meta.url)), "..", "..");
const vectors = join(root, "tests", "conformance");
const modulePath = process.env.PATCHVIS_MODULE ?? join(root, "npm", "patchvis.mjs");
const { Reader, PatchvisError } = await import(pathToFileURL(modulePath).href);
const reader = await Reader.load(); // the module's own patchvis.wasm

const number = (s) => (s === "inf" ? Infinity : s === "-inf" ? -Infinity : Number(s));
const list = (s) => (s === "" ? [] : s.split(",").map(Number));
const failures = [];

let queries = 0;
let shellQueries = 0; // of files with sampling shells
let farQueries = 0; // of files with sampling shells, eyes beyond the sampling distance

function check(name, ok, what) {
  if (!ok) failures.push(`${name}: ${what}`);
}

for (const entry of readdirSync(join(vectors, "valid")).filter((f) => f.endsWith(".pvis")).sort()) {
  const name = `valid/${entry}`;
  const dump = readFileSync(join(vectors, "valid", entry.replace(/\.pvis$/, ".dump")), "utf8");
  const lines = dump.split("\n");
  const field = (key) => Number(lines.find((l) => l.startsWith(`${key}: `)).split(": ")[1]);
  let file;
  try {
    file = reader.open(readFileSync(join(vectors, "valid", entry)));
  } catch (e) {
    check(name, false, `refused: ${e.message}`);
    continue;
  }
  check(name, file.version === field("version"), `version ${file.version}`);
  check(name, file.patchCount === field("patches"), `patches ${file.patchCount}`);
  check(name, file.triangleCount === field("triangles"), `triangles ${file.triangleCount}`);
  check(name, file.level === field("level") && file.views === field("views"), "level/views");
  // The sampling sphere: `camera: center [x, y, z] radius r distance d ...`.
  const camera = /^camera: center \[([^\]]*)\] radius \S+ distance (\S+)/m.exec(dump);
  const center = camera ? camera[1].split(", ").map(number) : [0, 0, 0];
  const distance = camera ? number(camera[2]) : Infinity;
  const range = new Map();
  for (const l of lines) {
    const m = /^patch (\d+): first (\d+) count (\d+)$/.exec(l);
    if (m) range.set(Number(m[1]), [Number(m[2]), Number(m[3])]);
  }
  for (const l of lines) {
    if (!l.startsWith("query ")) continue;
    const m =
      /^query ([^ ]+) -> inside (true|false)(?: band (\d+) shells \[([^\]]*)\])? views \[([^\]]*)\](?: inner \[([^\]]*)\])? patches \[([^\]]*)\]$/.exec(
        l,
      );
    if (!m) {
      check(name, false, `${l}: not a query line this test reads`);
      continue;
    }
    queries++;
    const [x, y, z] = m[1].split(",").map(number);
    if (m[3] !== undefined) {
      shellQueries++;
      if (Math.hypot(x - center[0], y - center[1], z - center[2]) > distance) farQueries++;
    }
    const got = file.query(x, y, z);
    const patches = list(m[7]);
    const merged = [];
    for (const p of patches) {
      const [first, count] = range.get(p);
      const last = merged[merged.length - 1];
      if (last && last[0] + last[1] === first) last[1] += count;
      else merged.push([first, count]);
    }
    check(name, got.insideSphere === (m[2] === "true"), `${l}: inside ${got.insideSphere}`);
    check(name, got.views.join(",") === m[5], `${l}: views ${got.views}`);
    // Files with shells: the band, the shells and the inner shell's views too.
    if (m[3] !== undefined) {
      check(name, got.band === Number(m[3]), `${l}: band ${got.band}`);
      check(name, got.shells.join(",") === m[4], `${l}: shells ${got.shells}`);
      check(name, got.innerViews.join(",") === m[6], `${l}: inner ${got.innerViews}`);
    }
    check(name, Array.from(got.patches).join(",") === patches.join(","), `${l}: patches ${Array.from(got.patches)}`);
    check(name, JSON.stringify(got.ranges) === JSON.stringify(merged), `${l}: ranges ${JSON.stringify(got.ranges)}`);
  }
  file.close();
}

let refused = 0;
for (const entry of readdirSync(join(vectors, "invalid")).filter((f) => f.endsWith(".pvis")).sort()) {
  const name = `invalid/${entry}`;
  const expected = readFileSync(join(vectors, "invalid", entry.replace(/\.pvis$/, ".err")), "utf8").trimEnd();
  try {
    reader.open(readFileSync(join(vectors, "invalid", entry))).close();
    check(name, false, "accepted");
  } catch (e) {
    check(name, e instanceof PatchvisError, `threw ${e}`);
    check(name, e.message === expected, `message '${e.message}', expected '${expected}'`);
    refused++;
  }
}

// Every region was given back: a new file lands where the first one did.
check("memory", reader.top === reader.base, `top ${reader.top}, base ${reader.base}`);

if (failures.length > 0) {
  console.error(failures.slice(0, 30).join("\n"));
  console.error(`${failures.length} failures`);
  process.exit(1);
}
console.log(
  `wasm reader (${modulePath}): ${queries} queries (${shellQueries} of files with sampling shells, ${farQueries} ` +
    `of them beyond the sampling distance) and ${refused} refusals match the conformance vectors`,
);
