// The WebAssembly reader (npm/patchvis.wasm through npm/patchvis.mjs) as a peer of
// `patchvis conformance`: answers the harness's line protocol (tests/conformance/README.md,
// "Testing another reader") on stdin and stdout.
//
//   patchvis conformance --reader 'node tests/wasm/adapter.mjs'
//
// The module has no frustum query, so the adapter does not declare `frustum`.
import { readFileSync } from "node:fs";
import { createInterface } from "node:readline";
import { Reader } from "../../npm/patchvis.mjs";

const reader = await Reader.load(); // the package's own npm/patchvis.wasm
const number = (s) => (s === "inf" ? Infinity : s === "-inf" ? -Infinity : Number(s));

let file = null;
function answer(line) {
  const space = line.indexOf(" ");
  const verb = space < 0 ? line : line.slice(0, space);
  const rest = space < 0 ? "" : line.slice(space + 1);
  switch (verb) {
    case "hello":
      return "hello 1";
    case "open": {
      file?.close();
      file = null;
      let bytes;
      try {
        bytes = readFileSync(rest);
      } catch (e) {
        return `error ${rest}: ${e.message}`;
      }
      try {
        file = reader.open(bytes);
        return "ok";
      } catch (e) {
        return `error ${e.message}`;
      }
    }
    case "query": {
      if (!file) return "error no file is open";
      const [x, y, z] = rest.split(",").map(number);
      const v = file.query(x, y, z);
      return (
        `inside ${v.insideSphere} band ${v.band} shells [${v.shells}] views [${v.views}] ` +
        `inner [${v.innerViews}] patches [${Array.from(v.patches)}]`
      );
    }
    default:
      return `error unknown request '${verb}'`;
  }
}

for await (const line of createInterface({ input: process.stdin })) {
  if (line === "quit") break;
  process.stdout.write(answer(line) + "\n");
}
file?.close();
