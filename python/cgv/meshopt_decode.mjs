// Undoes the meshopt compression of a GLB's buffer views (EXT_ or
// KHR_meshopt_compression), with meshoptimizer's own decoder, and writes the
// plain glTF (OUT) and its buffer (OUT.bin) for cgv.peers to read.
//
//   node meshopt_decode.mjs PATH/TO/meshopt_decoder.mjs IN.glb OUT.gltf
import { readFileSync, writeFileSync } from 'node:fs';
import { pathToFileURL } from 'node:url';

const [decoderPath, input, output] = process.argv.slice(2);
const { MeshoptDecoder } = await import(pathToFileURL(decoderPath).href);
await MeshoptDecoder.ready;

const glb = readFileSync(input);
if (glb.readUInt32LE(0) !== 0x46546c67) throw new Error(`${input}: not a GLB`);
const jsonLength = glb.readUInt32LE(12);
const json = JSON.parse(glb.subarray(20, 20 + jsonLength).toString('utf8'));
const binAt = 20 + jsonLength;
const bin = binAt + 8 <= glb.length ? glb.subarray(binAt + 8, binAt + 8 + glb.readUInt32LE(binAt)) : Buffer.alloc(0);

const parts = [];
let offset = 0;
json.bufferViews = json.bufferViews.map((view) => {
  const ext = view.extensions?.EXT_meshopt_compression ?? view.extensions?.KHR_meshopt_compression;
  let bytes;
  if (ext) {
    if ((ext.buffer ?? 0) !== 0) throw new Error(`${input}: compressed data outside the GLB's own buffer`);
    bytes = new Uint8Array(ext.count * ext.byteStride);
    const src = bin.subarray(ext.byteOffset ?? 0, (ext.byteOffset ?? 0) + ext.byteLength);
    MeshoptDecoder.decodeGltfBuffer(bytes, ext.count, ext.byteStride, src, ext.mode, ext.filter ?? 'NONE');
  } else if (view.buffer === 0) {
    bytes = bin.subarray(view.byteOffset ?? 0, (view.byteOffset ?? 0) + view.byteLength);
  } else {
    // A fallback buffer's view: its data is the compressed view's, decoded above.
    bytes = new Uint8Array(0);
  }
  const pad = (4 - (offset % 4)) % 4;
  parts.push(new Uint8Array(pad), bytes);
  offset += pad;
  const plain = { buffer: 0, byteOffset: offset, byteLength: bytes.length };
  if (view.byteStride) plain.byteStride = view.byteStride;
  offset += bytes.length;
  return plain;
});
json.buffers = [{ byteLength: offset }];
writeFileSync(output, JSON.stringify(json));
writeFileSync(`${output}.bin`, Buffer.concat(parts.map((p) => Buffer.from(p.buffer, p.byteOffset, p.byteLength))));
