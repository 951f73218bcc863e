// docs/benchmarks-web.md's mesh comparison: the Marching Cubes mesh of the same surface
// (`isogrid mc ... -o MESH.ply`, binary PLY) as a glTF 2.0 binary (positions float32, indices
// uint32: what a plain WebGPU or three.js mesh viewer draws; no normals) and Draco-compressed by
// gltf-pipeline (KHR_draco_mesh_compression; its defaults, positions quantised to 11 bits, and
// 14 bits); the file sizes and the Draco decode time in node (draco3dgltf's decoder, median of 3).
// Writes MESH.glb, MESH.draco11.glb and MESH.draco14.glb beside each PLY.
// Usage: node bench/gltf.mjs MODULES_DIR MESH.ply...
//   MODULES_DIR: a folder where `npm install gltf-pipeline@4.3.1 draco3dgltf@1.5.7` was run
//   (not dependencies of the viewer).
import { readFileSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import { join } from 'node:path';

const [modules, ...plys] = process.argv.slice(2);
const require = createRequire(join(modules, 'package.json'));
const { processGlb } = require('gltf-pipeline');
const draco3d = require('draco3dgltf');

/** Positions (float32 xyz) and triangle indices (uint32) of a binary little-endian PLY. */
export function readPly(bytes) {
  const end = bytes.indexOf('end_header\n') + 'end_header\n'.length;
  const header = bytes.subarray(0, end).toString('latin1');
  const nv = Number(/element vertex (\d+)/.exec(header)[1]);
  const nf = Number(/element face (\d+)/.exec(header)[1]);
  if (!/property float x\nproperty float y\nproperty float z\nelement face/.test(header) || !/list uchar uint/.test(header)) {
    throw new Error('expected float xyz vertices and uchar/uint faces (isogrid mc)');
  }
  const positions = new Float32Array(bytes.buffer.slice(bytes.byteOffset + end, bytes.byteOffset + end + 12 * nv));
  const indices = new Uint32Array(3 * nf);
  const view = new DataView(bytes.buffer, bytes.byteOffset + end + 12 * nv);
  for (let f = 0; f < nf; f++) {
    if (view.getUint8(13 * f) !== 3) throw new Error(`face ${f} is not a triangle`);
    for (let k = 0; k < 3; k++) indices[3 * f + k] = view.getUint32(13 * f + 1 + 4 * k, true);
  }
  return { positions, indices };
}

/** A glTF 2.0 binary of one indexed triangle mesh. */
export function writeGlb({ positions, indices }) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i++) {
    min[i % 3] = Math.min(min[i % 3], positions[i]);
    max[i % 3] = Math.max(max[i % 3], positions[i]);
  }
  const bin = Buffer.concat([Buffer.from(positions.buffer), Buffer.from(indices.buffer)]);
  const json = {
    asset: { version: '2.0', generator: 'isogrid web/bench/gltf.mjs' },
    scene: 0,
    scenes: [{ nodes: [0] }],
    nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1, mode: 4 }] }],
    buffers: [{ byteLength: bin.length }],
    bufferViews: [
      { buffer: 0, byteOffset: 0, byteLength: positions.byteLength, target: 34962 },
      { buffer: 0, byteOffset: positions.byteLength, byteLength: indices.byteLength, target: 34963 },
    ],
    accessors: [
      { bufferView: 0, componentType: 5126, count: positions.length / 3, type: 'VEC3', min, max },
      { bufferView: 1, componentType: 5125, count: indices.length, type: 'SCALAR' },
    ],
  };
  let text = Buffer.from(JSON.stringify(json));
  text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const header = Buffer.alloc(12);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + 8 + text.length + 8 + bin.length, 8);
  const chunk = (type, data) => {
    const h = Buffer.alloc(8);
    h.writeUInt32LE(data.length, 0);
    h.writeUInt32LE(type, 4);
    return [h, data];
  };
  return Buffer.concat([header, ...chunk(0x4e4f534a, text), ...chunk(0x004e4942, bin)]);
}

/** Decodes the Draco primitive of a GLB written by gltf-pipeline: positions and indices. */
function decodeDraco(decoderModule, glb) {
  const jsonLength = glb.readUInt32LE(12);
  const json = JSON.parse(glb.subarray(20, 20 + jsonLength).toString());
  const bin = glb.subarray(20 + jsonLength + 8);
  const ext = json.meshes[0].primitives[0].extensions.KHR_draco_mesh_compression;
  const view = json.bufferViews[ext.bufferView];
  const data = bin.subarray(view.byteOffset || 0, (view.byteOffset || 0) + view.byteLength);
  const decoder = new decoderModule.Decoder();
  const mesh = new decoderModule.Mesh();
  const status = decoder.DecodeArrayToMesh(data, data.length, mesh);
  if (!status.ok()) throw new Error(status.error_msg());
  const nf = mesh.num_faces();
  const indices = new Uint32Array(3 * nf);
  const ptr = decoderModule._malloc(indices.byteLength);
  decoder.GetTrianglesUInt32Array(mesh, indices.byteLength, ptr);
  indices.set(new Uint32Array(decoderModule.HEAPU32.buffer, ptr, 3 * nf));
  decoderModule._free(ptr);
  const attr = decoder.GetAttributeByUniqueId(mesh, ext.attributes.POSITION);
  const nv = mesh.num_points();
  const positions = new Float32Array(3 * nv);
  const pp = decoderModule._malloc(positions.byteLength);
  decoder.GetAttributeDataArrayForAllPoints(mesh, attr, decoderModule.DT_FLOAT32, positions.byteLength, pp);
  positions.set(new Float32Array(decoderModule.HEAPF32.buffer, pp, 3 * nv));
  decoderModule._free(pp);
  decoderModule.destroy(mesh);
  decoderModule.destroy(decoder);
  return { positions, indices };
}

const decoderModule = await draco3d.createDecoderModule({});
for (const ply of plys) {
  const mesh = readPly(readFileSync(ply));
  const glb = writeGlb(mesh);
  const base = ply.replace(/\.ply$/, '');
  writeFileSync(`${base}.glb`, glb);
  const row = { mesh: ply, vertices: mesh.positions.length / 3, triangles: mesh.indices.length / 3, glbBytes: glb.length };
  for (const bits of [11, 14]) {
    const t0 = performance.now();
    const { glb: draco } = await processGlb(glb, { dracoOptions: { compressionLevel: 7, quantizePositionBits: bits } });
    const encodeMs = performance.now() - t0;
    writeFileSync(`${base}.draco${bits}.glb`, draco);
    const times = [];
    let decoded;
    for (let i = 0; i < 3; i++) {
      const t1 = performance.now();
      decoded = decodeDraco(decoderModule, draco);
      times.push(performance.now() - t1);
    }
    times.sort((a, b) => a - b);
    if (decoded.indices.length !== mesh.indices.length) throw new Error(`draco ${bits}: ${decoded.indices.length / 3} triangles decoded`);
    row[`draco${bits}`] = { bytes: draco.length, encodeMs: Math.round(encodeMs), decodeMs: Math.round(times[1]) };
  }
  console.log(JSON.stringify(row));
}
