// Google Draco on one mesh, for the proxy bench: encodes with Edgebreaker and
// 14-bit positions (the proxy coder's setting; other options Draco's
// defaults), prints "bytes <n>" and "decode <M triangles a second>" (decoding
// to Draco's own mesh, in Node's WebAssembly). Input: a file of u32 vertex
// count, u32 triangle count, f32 xyz per vertex, u32 indices (little endian).
'use strict';
const fs = require('fs');
const medianRate = require('./median_rate.js');
const draco3d = require(process.env.DRACO3D || 'draco3d');

(async () => {
  const data = fs.readFileSync(process.argv[2]);
  const nv = data.readUInt32LE(0), nt = data.readUInt32LE(4);
  const positions = new Float32Array(data.buffer.slice(data.byteOffset + 8, data.byteOffset + 8 + nv * 12));
  const indices = new Uint32Array(data.buffer.slice(data.byteOffset + 8 + nv * 12, data.byteOffset + 8 + nv * 12 + nt * 12));
  const enc = await draco3d.createEncoderModule({});
  const dec = await draco3d.createDecoderModule({});
  const mesh = new enc.Mesh();
  const builder = new enc.MeshBuilder();
  builder.AddFacesToMesh(mesh, nt, indices);
  builder.AddFloatAttributeToMesh(mesh, enc.POSITION, nv, 3, positions);
  const encoder = new enc.Encoder();
  encoder.SetAttributeQuantization(enc.POSITION, 14);
  encoder.SetEncodingMethod(enc.MESH_EDGEBREAKER_ENCODING);
  const out = new enc.DracoInt8Array();
  const length = encoder.EncodeMeshToDracoBuffer(mesh, out);
  if (length <= 0) throw new Error('Draco could not encode the mesh');
  const bytes = new Int8Array(length);
  for (let i = 0; i < length; i++) bytes[i] = out.GetValue(i);
  console.log(`bytes ${length}`);

  const decoder = new dec.Decoder();
  const rate = medianRate(() => {
    const buffer = new dec.DecoderBuffer();
    buffer.Init(bytes, bytes.length);
    const decoded = new dec.Mesh();
    const status = decoder.DecodeBufferToMesh(buffer, decoded);
    if (!status.ok() || decoded.num_faces() !== nt) throw new Error(`Draco decoding failed: ${status.error_msg()}`);
    dec.destroy(decoded);
    dec.destroy(buffer);
  });
  console.log(`decode ${(nt * rate / 1e6).toFixed(2)}`);
})().catch((e) => { console.error(e.message); process.exit(1); });
