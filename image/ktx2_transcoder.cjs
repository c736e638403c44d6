// Transcodes KTX2 (Basis Universal ETC1S or UASTC, any supercompression the transcoder reads)
// to RGBA8 with three.js's Basis transcoder (basis_transcoder.cjs + .wasm, beside this script).
// Run by image/ktx2_transcode.cpp as a child process, one run for all of a model's KTX2 images:
//
//   node ktx2_transcoder.cjs DIR COUNT MAX_PIXELS
//
// DIR holds this script, the transcoder, and the inputs 0.ktx2 .. COUNT-1.ktx2. For each input
// i it writes either i.rgba (width and height as two little-endian uint32, then width*height*4
// bytes, row 0 at the top: level 0, layer 0, face 0) or i.err (one line saying why). An image
// over MAX_PIXELS is refused before it is transcoded. Exit code 0 when every input was answered,
// 2 when the transcoder itself could not start (the reason on stderr, one line).
'use strict';

const fs = require('fs');
const path = require('path');

const kRGBA32 = 13;  // basisu's transcoder_texture_format::cTFRGBA32 (KTX2Loader's RGBA32)

function transcodeOne(basis, bytes, maxPixels) {
  const file = new basis.KTX2File(new Uint8Array(bytes));
  try {
    if (!file.isValid()) return {error: 'not a valid KTX2 file'};
    if (!file.isETC1S() && !file.isUASTC())
      return {error: 'not ETC1S or UASTC (only those Basis Universal modes are read)'};
    const width = file.getWidth(), height = file.getHeight();
    if (width <= 0 || height <= 0) return {error: 'its size is 0'};
    if (width * height > maxPixels)
      return {error: `image is ${width}x${height}, over the limit of ${maxPixels} pixels`};
    if (file.getLevels() < 1) return {error: 'it has no mip level'};
    if (!file.startTranscoding()) return {error: 'its data could not be read (damaged?)'};
    const size = file.getImageTranscodedSizeInBytes(0, 0, 0, kRGBA32);
    if (size !== width * height * 4) return {error: 'the transcoder gave an unexpected size'};
    const out = Buffer.alloc(8 + size);
    out.writeUInt32LE(width, 0);
    out.writeUInt32LE(height, 4);
    const pixels = new Uint8Array(out.buffer, out.byteOffset + 8, size);
    // level 0, layer 0, face 0; alpha for opaque formats, no channel swizzle
    if (!file.transcodeImage(pixels, 0, 0, 0, kRGBA32, 0, -1, -1))
      return {error: 'its level 0 could not be transcoded (damaged?)'};
    return {rgba: out};
  } finally {
    file.close();
    file.delete();
  }
}

async function main() {
  const [dir, countText, maxText] = process.argv.slice(2);
  const count = Number(countText), maxPixels = Number(maxText);
  if (!dir || !(count >= 0) || !(maxPixels > 0)) {
    process.stderr.write('usage: node ktx2_transcoder.cjs DIR COUNT MAX_PIXELS\n');
    process.exit(2);
  }
  let basis;
  try {
    const factory = require(path.join(dir, 'basis_transcoder.cjs'));
    const wasmBinary = fs.readFileSync(path.join(dir, 'basis_transcoder.wasm'));
    basis = await factory({wasmBinary, print: () => {}, printErr: () => {}});
    basis.initializeBasis();
  } catch (e) {
    process.stderr.write(`the Basis transcoder did not start: ${String(e.message || e)}\n`);
    process.exit(2);
  }
  for (let i = 0; i < count; ++i) {
    let result;
    try {
      result = transcodeOne(basis, fs.readFileSync(path.join(dir, `${i}.ktx2`)), maxPixels);
    } catch (e) {
      result = {error: `the transcoder failed: ${String(e.message || e).split('\n')[0]}`};
    }
    if (result.rgba)
      fs.writeFileSync(path.join(dir, `${i}.rgba`), result.rgba);
    else
      fs.writeFileSync(path.join(dir, `${i}.err`), result.error + '\n');
  }
}

main().catch((e) => {
  process.stderr.write(`${String(e.message || e).split('\n')[0]}\n`);
  process.exit(2);
});
