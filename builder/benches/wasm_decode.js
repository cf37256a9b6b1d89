// The proxy decoder's speed in Node's WebAssembly, for the proxy bench:
// node wasm_decode.js MODULE.wasm FILE prints "decode <M triangles a second>".
'use strict';
const fs = require('fs');
const medianRate = require('./median_rate.js');

(async () => {
  const { instance } = await WebAssembly.instantiate(fs.readFileSync(process.argv[2]), {});
  const bytes = fs.readFileSync(process.argv[3]);
  const { buffer, decode, memory } = instance.exports;
  const ptr = buffer(bytes.length);
  new Uint8Array(memory.buffer, ptr, bytes.length).set(bytes);
  let triangles = 0;
  const rate = medianRate(() => {
    triangles = decode(bytes.length);
    if (triangles < 0) throw new Error('the file does not decode');
  });
  console.log(`decode ${(triangles * rate / 1e6).toFixed(2)}`);
})().catch((e) => { console.error(e.message); process.exit(1); });
