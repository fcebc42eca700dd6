// Independent reference for our glTF output: three.js GLTFLoader under node.
//
//   node tests/crosscheck/three_gltf.mjs FILE.glb FRAME... [--out PATH]
//
// Prints (or writes to PATH) one JSON object, as three_fk.mjs does:
//   {"reference": "three.js r<N> GLTFLoader", "file": ..., "frame_count": N,
//    "frame_time_s": T, "units": "m",
//    "parents": {"<joint>": "<parent joint>" or null, ...},
//    "frames": {"<frame>": {"<joint>": [x, y, z], ...}, ...}}
// World joint origins in metres, glTF axes (+Y up). FRAME is 0-based;
// negative values count from the end (-1 = last frame). Joints are named by
// the file's node names (three.js sanitises object names, so objects are
// mapped back to their nodes through the parser's associations).
//
// Each frame is applied as three_fk.mjs does: every track's own interpolant
// is evaluated at the keyframe time of that frame and written through a
// PropertyBinding (what AnimationMixer does, without its loop wrap-around),
// then world matrices are updated from the scene and each joint's world
// origin is read.
import { readFileSync, writeFileSync } from 'node:fs';
import { PropertyBinding, REVISION, Vector3 } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

function usage(message) {
  process.stderr.write(`three_gltf.mjs: ${message}\n` +
    'usage: node three_gltf.mjs FILE.glb FRAME... [--out PATH]\n');
  process.exit(2);
}

const args = process.argv.slice(2);
let outPath = null;
const positional = [];
for (let i = 0; i < args.length; i++) {
  if (args[i] === '--out') {
    if (i + 1 >= args.length) usage('--out needs a path');
    outPath = args[++i];
  } else {
    positional.push(args[i]);
  }
}
if (positional.length < 2) usage('need a .glb file and at least one frame');
const file = positional[0];
const requested = positional.slice(1).map((s) => {
  if (!/^-?\d+$/.test(s)) usage(`not a frame number: ${s}`);
  return Number.parseInt(s, 10);
});

const bytes = readFileSync(file);
const data = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const gltf = await new GLTFLoader().parseAsync(data, '');
if (gltf.animations.length !== 1) throw new Error(`${file}: ${gltf.animations.length} animations`);
const clip = gltf.animations[0];
const scene = gltf.scene;

// Objects of the file's nodes, by node name.
const nodeNames = gltf.parser.json.nodes.map((n) => n.name);
const byName = new Map();
scene.traverse((object) => {
  const association = gltf.parser.associations.get(object);
  if (association !== undefined && association.nodes !== undefined) {
    byName.set(nodeNames[association.nodes], object);
  }
});
const nameOf = new Map([...byName].map(([name, object]) => [object, name]));

const bindings = clip.tracks.map((track) => ({
  track,
  interpolant: track.createInterpolant(),
  binding: PropertyBinding.create(scene, track.name),
}));
if (bindings.length === 0) throw new Error(`${file}: no animation tracks`);
const frameCount = bindings[0].track.times.length;
for (const b of bindings) {
  if (b.track.times.length !== frameCount) throw new Error(`${b.track.name}: frame count differs`);
}
const times = bindings[0].track.times;
const frameTime = frameCount > 1 ? times[frameCount - 1] / (frameCount - 1) : null;

const parents = {};
for (const [name, object] of byName) {
  parents[name] = nameOf.has(object.parent) ? nameOf.get(object.parent) : null;
}

const frames = {};
const world = new Vector3();
for (const f of requested) {
  const frame = f < 0 ? frameCount + f : f;
  if (frame < 0 || frame >= frameCount) usage(`frame ${f} out of range (file has ${frameCount})`);
  for (const { track, interpolant, binding } of bindings) {
    binding.setValue(interpolant.evaluate(track.times[frame]), 0);
  }
  scene.updateMatrixWorld(true);
  const joints = {};
  for (const [name, object] of byName) {
    object.getWorldPosition(world);
    joints[name] = [world.x, world.y, world.z];
  }
  frames[String(frame)] = joints;
}

const result = {
  reference: `three.js r${REVISION} GLTFLoader`,
  file,
  frame_count: frameCount,
  frame_time_s: frameTime,
  units: 'm',
  parents,
  frames,
};
const json = JSON.stringify(result);
if (outPath !== null) {
  writeFileSync(outPath, json + '\n');
} else {
  process.stdout.write(json + '\n');
}
