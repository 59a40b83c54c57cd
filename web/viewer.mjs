// The patchvis viewer: draws a `patchvis bake --mesh-out X.glb` mesh with only the triangle
// ranges that the WebAssembly reader returns for the camera, with three.js (WebGL2). The
// reader and its three.js helper are the npm package (npm/: `patchvis`, `patchvis/three`,
// copied into demo/patchvis/ by build.sh and named in index.html's import map), used as an
// application would use them: `meshParts` lists the glTF's primitives and their triangles,
// `drawRanges` and `setDrawRanges` turn an answer into draw groups (three.mjs says why that
// works).
//
// Loads demo/bunny.glb + demo/bunny.pvis (web/build.sh makes them), or a .glb and .pvis
// dropped on the page. Test hook: window.patchvis (see the end of this file).

import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { FlyControls } from "three/addons/controls/FlyControls.js";
import { Reader } from "patchvis";
import { drawRanges, meshParts, setDrawRanges } from "patchvis/three";

const $ = (id) => document.getElementById(id);
const canvas = $("view");
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242b);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(45, 1, 0.001, 1000);
const orbit = new OrbitControls(camera, canvas);
const fly = new FlyControls(camera, canvas);
fly.dragToLook = true;
fly.enabled = false;
const clock = new THREE.Clock();

const reader = await Reader.load(); // the package's patchvis.wasm, fetched beside its module

/** What is loaded: the file, the drawn meshes, the last answer. */
const state = {
  name: "",
  file: null, // the open .pvis (PvisFile)
  model: null, // the glTF's parts (meshParts)
  root: null, // the glTF scene
  parts: [], // { mesh, colourMesh, first, count }: one per glTF primitive
  triangles: 0,
  answer: null, // { patches, ranges, inside, band, shells }
  drawn: 0, // triangles drawn
  lastEye: null,
  bounds: null, // the model's bounding sphere (THREE.Sphere)
  options: { culling: true, colours: false },
};

/** Loads a .glb (ArrayBuffer) and its .pvis (ArrayBuffer); throws on a mismatch. */
async function load(name, glbBytes, pvisBytes) {
  const file = reader.open(new Uint8Array(pvisBytes)); // throws PatchvisError
  const gltf = await new GLTFLoader().parseAsync(glbBytes, "./");
  let model;
  try {
    model = meshParts(gltf, file);
  } catch (err) {
    file.close();
    throw new Error(`${name}: ${err.message}`);
  }
  unload();
  const parts = model.parts.map((part) => {
    part.mesh.frustumCulled = false;
    const colourMesh = patchColourMesh(part.mesh, part.first, model.patchFirstTriangle);
    part.mesh.parent.add(colourMesh);
    return { ...part, colourMesh };
  });
  scene.add(gltf.scene);
  Object.assign(state, { name, file, model, root: gltf.scene, parts, triangles: model.triangleCount });
  frame(gltf.scene);
  $("name").textContent = `${name}: ${file.patchCount} patches, ${model.triangleCount} triangles`;
  $("error").textContent = "";
  update(true);
}

/** Removes what is loaded. */
function unload() {
  if (state.root) scene.remove(state.root);
  state.file?.close();
  Object.assign(state, { file: null, model: null, root: null, parts: [], answer: null, lastEye: null });
}

/**
 * A copy of a primitive's mesh with one flat colour per patch: the geometry unindexed (so
 * that a vertex belongs to one triangle), triangle k of the primitive coloured by its patch.
 */
function patchColourMesh(mesh, first, patchFirsts) {
  const geometry = mesh.geometry.toNonIndexed();
  const triangles = geometry.attributes.position.count / 3;
  const colours = new Float32Array(9 * triangles);
  const colour = new THREE.Color();
  let patch = upperBound(patchFirsts, first) - 1;
  for (let k = 0; k < triangles; k++) {
    while (first + k >= patchFirsts[patch + 1]) patch++;
    // The hue stepped by the golden ratio, as the PLY's patch colours.
    colour.setHSL((patch * 0.618033988749895) % 1, 0.75, patch % 14 < 7 ? 0.55 : 0.4);
    for (let c = 0; c < 3; c++) colour.toArray(colours, 9 * k + 3 * c);
  }
  geometry.setAttribute("color", new THREE.BufferAttribute(colours, 3));
  geometry.deleteAttribute("uv");
  const material = new THREE.MeshLambertMaterial({ vertexColors: true });
  const copy = new THREE.Mesh(geometry, [material]);
  copy.frustumCulled = false;
  copy.visible = false;
  return copy;
}

/** The first index whose value is greater than `x` in the ascending `values`. */
function upperBound(values, x) {
  let lo = 0;
  let hi = values.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (values[mid] <= x) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

/**
 * The first view: the model upright and from the front in glTF's axes (+Y up, the front
 * facing +Z), a little from above and to the side, far enough out that its bounding sphere
 * fits the part of the canvas beside the overlay (frameBesideOverlay), and outside the
 * sampling sphere (2.61 radii at the bake's default field of view).
 */
function frame(object) {
  const box = new THREE.Box3().setFromObject(object);
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  state.bounds = sphere;
  const free = freeRegion();
  // The distance at which the sphere fits the free region's height and width.
  const halfHeight = THREE.MathUtils.degToRad(camera.fov / 2);
  const halfWidth = Math.atan(Math.tan(halfHeight) * (free.width / free.height));
  const fit = sphere.radius / Math.sin(Math.min(halfHeight, halfWidth));
  const direction = new THREE.Vector3(0.45, 0.3, 1).normalize();
  camera.up.set(0, 1, 0);
  camera.position.copy(sphere.center).addScaledVector(direction, Math.max(3.2 * sphere.radius, fit));
  orbit.target.copy(sphere.center);
  fly.movementSpeed = sphere.radius;
  camera.lookAt(sphere.center);
  frameBesideOverlay();
  clip();
}

/**
 * The part of the canvas the overlay leaves free, in CSS pixels: right of it when that leaves
 * at least 40 % of the width, else below it when that leaves 40 % of the height, else all.
 */
function freeRegion() {
  const { clientWidth: w, clientHeight: h } = canvas;
  const panel = $("overlay").getBoundingClientRect();
  if (w - panel.right >= 0.4 * w) return { x: panel.right, y: 0, width: w - panel.right, height: h };
  if (h - panel.bottom >= 0.4 * h) return { x: 0, y: panel.bottom, width: w, height: h - panel.bottom };
  return { x: 0, y: 0, width: w, height: h };
}

/**
 * Shifts the image so that the point the camera looks at (the orbit's target) shows at the
 * centre of the free region rather than under the overlay; the eye, and so the answer, stay
 * as they are.
 */
function frameBesideOverlay() {
  const { clientWidth: w, clientHeight: h } = canvas;
  if (w === 0 || h === 0) return;
  const free = freeRegion();
  const dx = free.x + free.width / 2 - w / 2;
  const dy = free.y + free.height / 2 - h / 2;
  camera.setViewOffset(w, h, -dx, -dy, w, h);
}

/** Near and far planes that hold the model from wherever the camera is, near or far. */
function clip() {
  if (!state.bounds) return;
  const { center, radius } = state.bounds;
  const d = camera.position.distanceTo(center);
  const near = Math.max(radius / 100, (d - radius) / 2);
  const far = Math.max(radius * 100, 2 * (d + radius));
  if (near !== camera.near || far !== camera.far) {
    camera.near = near;
    camera.far = far;
    camera.updateProjectionMatrix();
  }
}

/** Queries the reader for the camera (when it moved, or `force`) and sets the draw groups. */
function update(force = false) {
  if (!state.file) return;
  clip();
  const eye = camera.position;
  if (force || !state.lastEye || !state.lastEye.equals(eye)) {
    const t0 = performance.now();
    const answer = state.file.query(eye.x, eye.y, eye.z);
    const ms = performance.now() - t0;
    state.answer = {
      raw: answer,
      patches: Array.from(answer.patches),
      ranges: answer.ranges,
      inside: answer.insideSphere,
      band: answer.band,
      shells: answer.shells,
    };
    state.lastEye = eye.clone();
    // Browsers coarsen the clock (to 0.1 ms without cross-origin isolation).
    $("time").textContent = ms > 0 ? `${ms.toFixed(3)} ms` : "< 0.1 ms";
  }
  const { raw, inside, patches, band, shells } = state.answer;
  // The answer comes from the sampling shells around the camera, near the model or far from
  // it; only nearer than the innermost shell's cameras is it approximate, and everything is
  // drawn there (drawRanges).
  const all = !state.options.culling || inside;
  const draw = state.options.culling ? drawRanges(state.model, raw) : [[0, state.triangles]];
  const shown = (part) => (state.options.colours ? part.colourMesh : part.mesh);
  for (const part of state.parts) {
    shown(part).visible = true;
    (state.options.colours ? part.mesh : part.colourMesh).visible = false;
  }
  const drawn = setDrawRanges(state.parts, draw, { geometry: (part) => shown(part).geometry });
  state.drawn = drawn;
  const patchCount = state.file.patchCount;
  $("patches").textContent = `${all ? patchCount : patches.length} / ${patchCount}`;
  $("triangles").textContent = `${drawn} / ${state.triangles} (${((100 * drawn) / state.triangles).toFixed(1)} %)`;
  // Shells are numbered from the outermost (0), the sampling sphere among them.
  const region = $("region");
  region.textContent = inside
    ? `inside the innermost shell (band ${band}): all drawn`
    : band === 0
      ? "beyond the outermost shell (band 0): answer valid"
      : `between shells ${shells[0]} and ${shells[1]} (band ${band}): answer valid`;
  region.className = inside ? "invalid" : "valid";
}

function resize() {
  const { clientWidth: w, clientHeight: h } = canvas;
  if (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio())) {
    renderer.setSize(w, h, false);
    frameBesideOverlay();
  }
}

function render() {
  resize();
  const delta = clock.getDelta();
  if (fly.enabled) fly.update(delta);
  else orbit.update();
  sun.position.copy(camera.position);
  update();
  renderer.render(scene, camera);
}
renderer.setAnimationLoop(render);

// Controls of the overlay.
$("culling").addEventListener("change", (e) => {
  state.options.culling = e.target.checked;
  update(true);
});
$("colours").addEventListener("change", (e) => {
  state.options.colours = e.target.checked;
  update(true);
});
$("fly").addEventListener("change", (e) => {
  fly.enabled = e.target.checked;
  orbit.enabled = !e.target.checked;
  if (!fly.enabled) {
    // Back to orbiting around the point the camera looks at.
    const ahead = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
    orbit.target.copy(camera.position).addScaledVector(ahead, camera.position.distanceTo(orbit.target));
  }
});

// Drag and drop of a .glb and its .pvis (together, or one after the other).
const dropped = {};
window.addEventListener("dragover", (e) => {
  e.preventDefault();
  document.body.classList.add("dragging");
});
window.addEventListener("dragleave", () => document.body.classList.remove("dragging"));
window.addEventListener("drop", async (e) => {
  e.preventDefault();
  document.body.classList.remove("dragging");
  for (const f of e.dataTransfer.files) {
    if (/\.glb$/i.test(f.name)) dropped.glb = f;
    else if (/\.pvis$/i.test(f.name)) dropped.pvis = f;
  }
  if (!dropped.glb || !dropped.pvis) {
    $("error").textContent = `now drop the ${dropped.glb ? ".pvis" : ".glb"} of the same bake`;
    return;
  }
  const { glb, pvis } = dropped;
  delete dropped.glb;
  delete dropped.pvis;
  try {
    await load(glb.name, await glb.arrayBuffer(), await pvis.arrayBuffer());
  } catch (err) {
    $("error").textContent = String(err.message ?? err);
  }
});

/** The test hook: drive the camera and read what the page would draw. */
window.patchvis = {
  ready: false,
  /** Moves the camera to `eye` looking at `target` and answers for it at once. */
  setCamera(eye, target) {
    camera.position.set(...eye);
    orbit.target.set(...target);
    camera.lookAt(...target);
    update(true);
    renderer.render(scene, camera);
  },
  /**
   * The last answer: visible patch ids, merged ranges, whether inside the innermost shell, the
   * band and the answering shells, and the triangles drawn of all.
   */
  answer() {
    const { raw, ...answer } = state.answer;
    return { ...answer, drawn: state.drawn, triangles: state.triangles };
  },
  /** Switches culling and patch colours. */
  setOptions({ culling, colours }) {
    if (culling !== undefined) state.options.culling = $("culling").checked = culling;
    if (colours !== undefined) state.options.colours = $("colours").checked = colours;
    update(true);
    renderer.render(scene, camera);
  },
  /** The loaded materials, in glTF order, as [name, has a base colour texture]. */
  materials() {
    const seen = new Map();
    for (const { mesh } of state.parts) {
      const m = mesh.material[0];
      seen.set(m.name, [m.name, !!m.map]);
    }
    return [...seen.values()].sort();
  },
  /**
   * Where the model shows, in CSS pixels: the bounds of its projected vertices, the overlay's
   * rectangle, the canvas size and the camera's up vector.
   */
  framing() {
    const model = { left: Infinity, top: Infinity, right: -Infinity, bottom: -Infinity };
    const { clientWidth: width, clientHeight: height } = canvas;
    const p = new THREE.Vector3();
    camera.updateMatrixWorld();
    for (const { mesh } of state.parts) {
      const positions = mesh.geometry.attributes.position;
      for (let i = 0; i < positions.count; i++) {
        p.fromBufferAttribute(positions, i).applyMatrix4(mesh.matrixWorld).project(camera);
        const [x, y] = [((p.x + 1) / 2) * width, ((1 - p.y) / 2) * height];
        Object.assign(model, {
          left: Math.min(model.left, x),
          top: Math.min(model.top, y),
          right: Math.max(model.right, x),
          bottom: Math.max(model.bottom, y),
        });
      }
    }
    const { left, top, right, bottom } = $("overlay").getBoundingClientRect();
    return { model, overlay: { left, top, right, bottom }, width, height, up: camera.up.toArray() };
  },
  /** Loads a .glb and .pvis pair from URLs (what a drop does with files). */
  async load(glbUrl, pvisUrl) {
    const [glb, pvis] = await Promise.all([glbUrl, pvisUrl].map((u) => fetch(u).then((r) => r.arrayBuffer())));
    await load(glbUrl.split("/").pop(), glb, pvis);
  },
};

try {
  await window.patchvis.load("./demo/bunny.glb", "./demo/bunny.pvis");
  window.patchvis.ready = true;
} catch (err) {
  $("error").textContent = `${err.message ?? err}\nRun bash web/build.sh to make the demo files.`;
  throw err;
}
