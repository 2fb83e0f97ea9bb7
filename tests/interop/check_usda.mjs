// Reads a run's usd/scene.usda with TinyUSDZ (a USD reader independent of ccfr; npm package
// `tinyusdz`, WebAssembly) and compares it with the run's OBJ frames:
//   node tests/interop/check_usda.mjs RUN_DIR [NODE_MODULES_DIR]
// 1. TinyUSDZ's render-scene conversion (loadFromBinary, getMesh): every Mesh prim's
//    faceVertexIndices against the OBJ faces of its object, its points against the frame of the
//    layer's default time.
// 2. The layer TinyUSDZ parsed, written back by TinyUSDZ (layerToString): every time sample of every
//    prim's points against the OBJ frame of that number (float32 rounding: < 1e-6 m).
// Prints "RESULT {json}" and exits non-zero on a mismatch.
import fs from 'fs';
import path from 'path';

const runDir = process.argv[2];
const modules = process.argv[3] || path.join(path.dirname(new URL(import.meta.url).pathname), 'node_modules');
// The npm build targets browsers only: present one (a window, an Electron-style renderer process)
// and hand over the wasm bytes instead of letting it fetch them.
globalThis.window = globalThis;
process.type = 'renderer';
const { default: init } = await import(path.join(modules, 'tinyusdz', 'tinyusdz.js'));
const native = await init({ wasmBinary: fs.readFileSync(path.join(modules, 'tinyusdz', 'tinyusdz.wasm')) });

function fail(msg) {
  console.log('FAIL ' + msg);
  process.exit(1);
}

function readObj(frame) {
  const file = path.join(runDir, 'frames', 'frame_' + String(frame).padStart(5, '0') + '.obj');
  const objects = [];
  const v = [];
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    if (line.startsWith('o ')) objects.push({ name: line.slice(2), begin: v.length, faces: [] });
    else if (line.startsWith('v ')) v.push(line.slice(2).trim().split(/\s+/).map(Number));
    else if (line.startsWith('f ')) objects[objects.length - 1].faces.push(...line.slice(2).trim().split(/\s+/).map((s) => parseInt(s, 10) - 1));
  }
  for (let i = 0; i < objects.length; ++i) objects[i].end = i + 1 < objects.length ? objects[i + 1].begin : v.length;
  return { v, objects };
}

const bytes = new Uint8Array(fs.readFileSync(path.join(runDir, 'usd', 'scene.usda')));

// 1. Render scene: topology and default-time points per mesh.
const scene = new native.TinyUSDZLoaderNative();
if (!scene.loadFromBinary(bytes, 'scene.usda')) fail('TinyUSDZ cannot load the file: ' + scene.error());
const first = readObj(0);
const meshObjects = first.objects.filter((o) => o.faces.length > 0);
if (scene.numMeshes() !== meshObjects.length) fail(`TinyUSDZ sees ${scene.numMeshes()} meshes, the OBJ has ${meshObjects.length}`);
let renderError = 0;
for (let i = 0; i < scene.numMeshes(); ++i) {
  const m = scene.getMesh(i), o = meshObjects[i];
  const idx = Array.from(m.faceVertexIndices);
  if (idx.length !== o.faces.length) fail(`mesh ${i}: ${idx.length} indices, OBJ ${o.faces.length}`);
  for (let k = 0; k < idx.length; ++k)
    if (idx[k] + o.begin !== o.faces[k]) fail(`mesh ${i}: index ${k} is ${idx[k]}, OBJ ${o.faces[k] - o.begin}`);
  const p = m.points;
  if (p.length !== 3 * (o.end - o.begin)) fail(`mesh ${i}: ${p.length / 3} points, OBJ ${o.end - o.begin}`);
  for (let v = 0; v < p.length / 3; ++v)
    for (let c = 0; c < 3; ++c) renderError = Math.max(renderError, Math.abs(p[3 * v + c] - first.v[o.begin + v][c]));
}

// 2. Every time sample, from TinyUSDZ's own serialisation of the layer it parsed.
const layer = new native.TinyUSDZLoaderNative();
if (!layer.loadAsLayerFromBinary(bytes, 'scene.usda')) fail('TinyUSDZ cannot load the layer: ' + layer.error());
const text = layer.layerToString();
const prims = [];
const primRe = /def (Mesh|Points|BasisCurves) "([^"]+)"/g;
let pm;
while ((pm = primRe.exec(text)) !== null) prims.push({ type: pm[1], name: pm[2], at: pm.index });
if (prims.length !== first.objects.length) fail(`TinyUSDZ's layer has ${prims.length} prims, the OBJ ${first.objects.length} objects`);
let maxError = 0, samples = 0;
const timeCodes = new Set();
for (let i = 0; i < prims.length; ++i) {
  const body = text.slice(prims[i].at, i + 1 < prims.length ? prims[i + 1].at : text.length);
  const ts = body.indexOf('points.timeSamples');
  if (ts < 0) fail(`prim ${prims[i].name} has no points.timeSamples`);
  const sampleRe = /(\d+(?:\.\d+)?)\s*:\s*\[([^\]]*)\]/g;
  sampleRe.lastIndex = ts;
  let sm;
  const o = first.objects[i];
  while ((sm = sampleRe.exec(body)) !== null) {
    const frame = Number(sm[1]);
    timeCodes.add(frame);
    const nums = sm[2].match(/-?[\d.]+(?:e[-+]?\d+)?/gi).map(Number);
    const ref = readObj(frame);
    if (nums.length !== 3 * (o.end - o.begin)) fail(`prim ${prims[i].name} time ${frame}: ${nums.length / 3} points`);
    for (let v = 0; v < nums.length / 3; ++v)
      for (let c = 0; c < 3; ++c) maxError = Math.max(maxError, Math.abs(nums[3 * v + c] - ref.v[o.begin + v][c]));
    ++samples;
  }
}
const result = { prims: prims.length, meshes: scene.numMeshes(), time_codes: timeCodes.size, samples,
                 max_error: maxError, render_scene_error: renderError };
console.log('RESULT ' + JSON.stringify(result));
if (!(maxError < 1e-6) || !(renderError < 1e-6)) fail('points differ from the OBJ frames');
