// Independent forward-kinematics reference: three.js BVHLoader under node.
//
//   node tests/crosscheck/three_fk.mjs FILE.bvh FRAME... [--out PATH]
//
// Prints (or writes to PATH) one JSON object:
//   {"reference": "three.js <version> BVHLoader", "file": ..., "frame_count": N,
//    "frame_time_s": T, "units": "file",
//    "parents": {"<joint>": "<parent joint>" or null, ...},
//    "frames": {"<frame>": {"<joint>": [x, y, z], ...}, ...}}
// World joint origins in FILE units, BVH axes (no scaling, no axis change).
// FRAME is 0-based; negative values count from the end (-1 = last frame).
//
// three.js ADDS position channels to the OFFSET (BVHLoader, toTHREEAnimation),
// whereas our rule (and Blender's) is that they REPLACE it. The two agree only
// when every joint with position channels has OFFSET 0 0 0 (e.g. the CMU
// files: only the root has position channels and its OFFSET is zero), so this
// script refuses other files (exit 3) instead of producing a misleading
// reference.
//
// Each frame is applied by evaluating the clip's own keyframe tracks (their
// interpolants, as AnimationMixer does) at the keyframe time of that frame,
// which avoids the mixer's loop wrap-around at the clip's end; then world
// matrices are updated from the root and each bone's world origin is read.
import { readFileSync, writeFileSync } from 'node:fs';
import { REVISION } from 'three';
import { BVHLoader } from 'three/examples/jsm/loaders/BVHLoader.js';

function usage(message) {
  process.stderr.write(`three_fk.mjs: ${message}\n` +
    'usage: node three_fk.mjs FILE.bvh FRAME... [--out PATH]\n');
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
if (positional.length < 2) usage('need a BVH file and at least one frame');
const file = positional[0];
const requested = positional.slice(1).map((s) => {
  if (!/^-?\d+$/.test(s)) usage(`not a frame number: ${s}`);
  return Number.parseInt(s, 10);
});

const text = readFileSync(file, 'utf8');

// Applicability: no joint may have both position channels and a non-zero
// OFFSET (see the header). Checked on the raw text, independently of the loader.
{
  const tokens = text.split(/\s+/).filter((t) => t.length > 0);
  let name = null;
  let offset = null;
  for (let i = 0; i < tokens.length; i++) {
    const t = tokens[i];
    if (t === 'MOTION') break;
    if (t === 'ROOT' || t === 'JOINT') {
      name = tokens[i + 1];
      offset = null;
    } else if (t === 'End') {
      name = null;
    } else if (t === 'OFFSET') {
      offset = tokens.slice(i + 1, i + 4).map(Number);
    } else if (t === 'CHANNELS' && name !== null) {
      const n = Number.parseInt(tokens[i + 1], 10);
      const channels = tokens.slice(i + 2, i + 2 + n);
      const hasPosition = channels.some((c) => /position$/i.test(c));
      if (hasPosition && offset !== null && offset.some((v) => v !== 0)) {
        process.stderr.write(`three_fk.mjs: ${file}: joint ${name} has position channels and ` +
          `OFFSET ${offset.join(' ')}; three.js adds them (our rule replaces), ` +
          'so three.js is no reference for this file\n');
        process.exit(3);
      }
    }
  }
}

const { skeleton, clip } = new BVHLoader().parse(text);
const bones = skeleton.bones;
const root = bones[0];
const byName = new Map();
for (const bone of bones) {
  if (bone.name !== 'ENDSITE') byName.set(bone.name, bone);  // End Sites: no joint
}

// Bind every track to its bone and property.
const bindings = clip.tracks.map((track) => {
  const dot = track.name.lastIndexOf('.');
  const boneName = track.name.slice(0, dot);
  const property = track.name.slice(dot + 1);
  const bone = byName.get(boneName);
  if (bone === undefined || (property !== 'position' && property !== 'quaternion')) {
    throw new Error(`unexpected track ${track.name}`);
  }
  return { track, bone, property, interpolant: track.createInterpolant() };
});
if (bindings.length === 0) throw new Error(`${file}: no animation tracks`);
const frameCount = bindings[0].track.times.length;
for (const b of bindings) {
  if (b.track.times.length !== frameCount) throw new Error(`${b.track.name}: frame count differs`);
}
const frameTimeMatch = /Frame\s+Time:\s*(\S+)/i.exec(text);
const frameTime = frameTimeMatch ? Number(frameTimeMatch[1]) : null;

const parents = {};
for (const [name, bone] of byName) {
  parents[name] = bone.parent !== null && bone.parent.isBone ? bone.parent.name : null;
}

const frames = {};
for (const f of requested) {
  const frame = f < 0 ? frameCount + f : f;
  if (frame < 0 || frame >= frameCount) usage(`frame ${f} out of range (file has ${frameCount})`);
  for (const { track, bone, property, interpolant } of bindings) {
    const v = interpolant.evaluate(track.times[frame]);
    if (property === 'position') {
      bone.position.set(v[0], v[1], v[2]);
    } else {
      bone.quaternion.set(v[0], v[1], v[2], v[3]);
    }
  }
  root.updateMatrixWorld(true);
  const joints = {};
  for (const [name, bone] of byName) {
    const e = bone.matrixWorld.elements;  // column-major; translation = 12..14
    joints[name] = [e[12], e[13], e[14]];
  }
  frames[String(frame)] = joints;
}

const result = {
  reference: `three.js r${REVISION} BVHLoader`,
  file,
  frame_count: frameCount,
  frame_time_s: frameTime,
  units: 'file',
  parents,
  frames,
};
const json = JSON.stringify(result);
if (outPath !== null) {
  writeFileSync(outPath, json + '\n');
} else {
  process.stdout.write(json + '\n');
}
