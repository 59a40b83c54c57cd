// Turns the bundled bunny (assets/bunny.ply: Z up, facing −X) to glTF's axes (Y up, facing +Z),
// so that the viewer's demo stands upright and faces the first view: each vertex (x, y, z)
// becomes (−y, z, −x), a rotation, so the triangles keep their winding. Reads a binary
// little-endian PLY whose vertices are exactly `float x, y, z`; copies the faces unchanged.
//
//   node web/bunny-y-up.mjs assets/bunny.ply OUT.ply
import { readFileSync, writeFileSync } from "node:fs";

const [input, output] = process.argv.slice(2);
const bytes = readFileSync(input);
const end = bytes.indexOf("end_header\n");
if (end < 0) throw new Error(`${input}: no PLY header`);
const body = end + "end_header\n".length;
const header = bytes.subarray(0, body).toString("latin1").split("\n");
const vertexAt = header.findIndex((line) => line.startsWith("element vertex "));
const vertices = Number(header[vertexAt]?.split(" ")[2]);
const properties = header.slice(vertexAt + 1, vertexAt + 4).join(",");
if (
  !header.includes("format binary_little_endian 1.0") ||
  !(vertices > 0) ||
  properties !== "property float x,property float y,property float z" ||
  header[vertexAt + 4].startsWith("property")
) {
  throw new Error(`${input}: expected binary little-endian vertices of float x, y, z`);
}
const out = Buffer.from(bytes);
for (let i = 0; i < vertices; i++) {
  const at = body + 12 * i;
  const [x, y, z] = [0, 4, 8].map((k) => bytes.readFloatLE(at + k));
  out.writeFloatLE(-y, at);
  out.writeFloatLE(z, at + 4);
  out.writeFloatLE(-x, at + 8);
}
writeFileSync(output, out);
