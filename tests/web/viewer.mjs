// Drives the viewer (web/index.html) in headless Chromium and checks its answers against
// `patchvis query`: serves web/ on an ephemeral local port, loads the bunny demo (a default
// bake: shells near the model and far ones beyond the sampling distance D), moves the camera
// to positions spread over every band (inside the innermost shell, between each two shells, at
// D, and beyond the outermost shell up to 1000 D; 33 with the default shells), and for each
// compares the page's visible patches, ranges, inside flag, band and answering shells with the
// command's, and the triangles the page draws with the ranges' sum (everything only inside the
// innermost shell). Fails on any console error, page error or failed request, on fewer than 24
// eyes, if a band has no eye, or if the first view puts the model under the overlay, off the
// canvas or not upright. Writes a screenshot of the first view. Used by tests/web/run.sh.
//
//   node tests/web/viewer.mjs PATCHVIS_BINARY SCREENSHOT.png
import { createServer } from "node:http";
import { readFile } from "node:fs/promises";
import { spawnSync } from "node:child_process";
import { createRequire } from "node:module";
import { extname, join, normalize } from "node:path";
import { fileURLToPath } from "node:url";

const [patchvis, screenshot] = process.argv.slice(2);
const web = fileURLToPath(new URL("../../web/", import.meta.url));
const { chromium } = createRequire(join(web, "package.json"))("playwright-core");
const CHROMIUM = process.env.CHROMIUM ?? "/usr/bin/chromium";
const PVIS = join(web, "demo/bunny.pvis");

function run(args) {
  const out = spawnSync(patchvis, args, { encoding: "utf8" });
  if (out.status !== 0) throw new Error(`patchvis ${args.join(" ")} failed: ${out.stderr}`);
  return JSON.parse(out.stdout);
}

// The eyes: Fibonacci directions around the sampling sphere's centre, 3 eyes at each distance:
// 1000 and 10 times the sampling distance D and 1.5 times the outermost shell's (band 0 where
// they lie beyond it), the geometric mean of each two neighbouring shells' distances (bands
// 1..K), D itself (either side of it, as the eye rounds), and 0.9 and 0.5 times the innermost
// shell's (band K + 1, drawn whole). The shells: the sampling sphere and the file's K others.
const info = run(["info", PVIS, "--json"]);
const { camera } = info;
const distances = [camera.distance, ...info.shells.map((s) => s.distance)].sort((a, b) => b - a);
const between = distances.slice(1).map((d, k) => Math.sqrt(d * distances[k]));
const innermost = distances[distances.length - 1];
const radii = [1000 * camera.distance, 10 * camera.distance, 1.5 * distances[0]];
radii.push(...between, camera.distance, 0.9 * innermost, 0.5 * innermost);
const eyes = [];
const n = 3 * radii.length;
for (let i = 0; i < n; i++) {
  const y = 1 - (2 * (i + 0.5)) / n;
  const r = Math.sqrt(1 - y * y);
  const phi = i * Math.PI * (3 - Math.sqrt(5));
  const d = radii[i % radii.length];
  eyes.push([0, 1, 2].map((k) => camera.center[k] + d * [r * Math.cos(phi), y, r * Math.sin(phi)][k]));
}

// A static server for web/ on an ephemeral port.
const types = { ".html": "text/html", ".mjs": "text/javascript", ".js": "text/javascript", ".wasm": "application/wasm" };
const server = createServer(async (req, res) => {
  const path = normalize(join(web, decodeURIComponent(new URL(req.url, "http://x").pathname)));
  const file = path.endsWith("/") ? join(path, "index.html") : path;
  if (!file.startsWith(web)) return res.writeHead(403).end();
  try {
    const body = await readFile(file);
    res.writeHead(200, { "content-type": types[extname(file)] ?? "application/octet-stream" }).end(body);
  } catch {
    res.writeHead(404).end();
  }
});
await new Promise((ok) => server.listen(0, "127.0.0.1", ok));
const url = `http://127.0.0.1:${server.address().port}/`;

const problems = [];
const browser = await chromium.launch({
  executablePath: CHROMIUM,
  headless: true,
  // WebGL2 on the CPU: ANGLE over SwiftShader (no GPU on CI).
  args: ["--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
});
try {
  const page = await browser.newPage({ viewport: { width: 720, height: 450 } });
  page.on("console", (m) => m.type() === "error" && problems.push(`console error: ${m.text()}`));
  page.on("pageerror", (e) => problems.push(`page error: ${e.message}`));
  page.on("requestfailed", (r) => problems.push(`request failed: ${r.url()} ${r.failure()?.errorText}`));
  page.on("response", (r) => r.status() >= 400 && problems.push(`HTTP ${r.status()}: ${r.url()}`));
  await page.goto(url);
  await page.waitForFunction(() => window.patchvis?.ready === true, null, { timeout: 60_000 });
  const webgl2 = await page.evaluate(() => !!document.createElement("canvas").getContext("webgl2"));
  if (!webgl2) problems.push("no WebGL2 context");

  const bands = new Map(); // band -> eyes
  for (const [i, eye] of eyes.entries()) {
    const page_ = await page.evaluate(
      ([eye, target]) => {
        window.patchvis.setCamera(eye, target);
        return window.patchvis.answer();
      },
      [eye, camera.center],
    );
    const cli = run(["query", PVIS, "--from", eye.join(","), "--json"]);
    const same =
      JSON.stringify(page_.patches) === JSON.stringify(cli.patches) &&
      JSON.stringify(page_.ranges) === JSON.stringify(cli.ranges) &&
      page_.inside === cli.inside_sphere &&
      page_.band === cli.band &&
      JSON.stringify(page_.shells) === JSON.stringify(cli.shells);
    if (!same) {
      problems.push(`eye ${i} (${eye}): page ${JSON.stringify(page_)} but patchvis query ${JSON.stringify(cli)}`);
      continue;
    }
    const expected = cli.inside_sphere ? page_.triangles : cli.ranges.reduce((s, [, n]) => s + n, 0);
    if (page_.drawn !== expected) problems.push(`eye ${i}: the page draws ${page_.drawn} triangles, expected ${expected}`);
    bands.set(cli.band, (bands.get(cli.band) ?? 0) + 1);
    const where = cli.inside_sphere ? ", inside the innermost shell" : "";
    console.log(`eye ${i}: band ${cli.band}, ${cli.patches.length} patches, ${page_.drawn} triangles${where}`);
  }
  for (let band = 0; band < distances.length + 1; band++) {
    if (!bands.has(band)) problems.push(`no eye in band ${band} (${distances.length - 1} shells)`);
  }
  if (eyes.length < 24) problems.push(`only ${eyes.length} eyes`);
  console.log(
    `bands: ${[...bands].sort(([a], [b]) => a - b).map(([b, k]) => `${k} eyes in band ${b}`).join(", ")}`,
  );

  // The user's own pair, dropped on the page: the globe (tests/data/obj, two materials, one
  // textured) baked by run.sh into web/demo/.
  await page.evaluate(async () => {
    const files = await Promise.all(
      ["globe.glb", "globe.pvis"].map(async (n) => new File([await (await fetch(`./demo/${n}`)).blob()], n)),
    );
    const dataTransfer = new DataTransfer();
    files.forEach((f) => dataTransfer.items.add(f));
    window.dispatchEvent(new DragEvent("drop", { dataTransfer, bubbles: true, cancelable: true }));
  });
  await page.waitForFunction(() => document.getElementById("name").textContent.startsWith("globe.glb"));
  const GLOBE = join(web, "demo/globe.pvis");
  const globe = run(["info", GLOBE, "--json"]).camera;
  for (const [i, eye] of eyes.slice(0, 6).entries()) {
    const scaled = eye.map((x, k) => globe.center[k] + ((x - camera.center[k]) * globe.distance) / camera.distance);
    const page_ = await page.evaluate(([e, t]) => (window.patchvis.setCamera(e, t), window.patchvis.answer()), [scaled, globe.center]);
    const cli = run(["query", GLOBE, "--from", scaled.join(","), "--json"]);
    const same =
      JSON.stringify(page_.patches) === JSON.stringify(cli.patches) &&
      page_.inside === cli.inside_sphere &&
      page_.band === cli.band;
    if (!same) {
      problems.push(`dropped globe, eye ${i}: page ${JSON.stringify(page_)} but patchvis query ${JSON.stringify(cli)}`);
    }
  }
  const materials = await page.evaluate(() => window.patchvis.materials());
  if (JSON.stringify(materials) !== JSON.stringify([["checker", true], ["paint", false]])) {
    problems.push(`dropped globe: materials ${JSON.stringify(materials)}, expected checker (textured) and paint`);
  }
  console.log("the dropped globe.glb + globe.pvis agree with patchvis query; materials and texture loaded");
  await page.evaluate(() => window.patchvis.load("./demo/bunny.glb", "./demo/bunny.pvis"));

  // Culling off draws everything.
  await page.evaluate(() => window.patchvis.setOptions({ culling: false }));
  const all = await page.evaluate(() => window.patchvis.answer());
  if (all.drawn !== all.triangles) problems.push(`culling off draws ${all.drawn} of ${all.triangles} triangles`);
  // The first view (the bunny reloaded above): the whole model on the canvas and clear of the
  // overlay, upright (+Y up). Then the screenshot, with patch colours and culling on.
  const { model, overlay, width, height, up } = await page.evaluate(() => window.patchvis.framing());
  const clear = model.left >= overlay.right || model.top >= overlay.bottom;
  const inside = model.left >= 0 && model.top >= 0 && model.right <= width && model.bottom <= height;
  if (!clear || !inside || up.join() !== "0,1,0") {
    problems.push(`first view: model ${JSON.stringify(model)} in ${width}×${height}, overlay ${JSON.stringify(overlay)}, up ${up}`);
  }
  await page.evaluate(() => window.patchvis.setOptions({ culling: true, colours: true }));
  await page.waitForTimeout(300);
  await page.screenshot({ path: screenshot });
  console.log(`${eyes.length} camera positions agree with patchvis query; screenshot: ${screenshot}`);
} finally {
  await browser.close();
  server.close();
}
if (problems.length > 0) {
  console.error(problems.join("\n"));
  process.exit(1);
}
