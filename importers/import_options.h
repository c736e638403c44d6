// Options shared by the importers, including the resource limits that keep a hostile upload
// (a few bytes that expand into gigabytes) from exhausting the machine. A limit of 0 means
// "from the input's size": the larger of a floor that every real model we know stays under
// and a multiple of the bytes the model's files hold (file + buffers + images).
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

namespace meshmux {

struct ImportOptions {
  bool decode_images = true;  // decode images to RGBA8 (needed by the atlas)
  uint64_t max_image_pixels = uint64_t(1)
                              << 28;            // refuse to decode larger images (hostile headers)
  uint64_t max_file_bytes = uint64_t(4) << 30;  // refuse larger input files
  bool allow_outside = false;  // read buffers and images outside the upload's root (trusted
                               // local use only: --allow-outside)
  std::string root;            // the upload's folder, bounding every read (importers/upload.h);
                               // "" = the model file's folder
  uint64_t max_texels = 0;     // decoded texels over all images (--max-texels); 0: from size
  uint64_t max_instances = 0;  // mesh instances after expanding the node graph
                               // (--max-instances); 0: from size
  uint64_t max_elements = 0;   // accessor elements (vertices, indices, instance attributes)
                               // read in all (--max-elements); 0: from size
};

// The limits used for an input whose files hold `input_bytes`: 0 fields resolved.
// Floors: 2^26 texels (a 8192² texture), 10^6 instances, 2^26 elements; the size terms give a
// model whose data really is that large what it needs (64 texels, 1/4 instance and 1 element
// per input byte). A 1 kB file thus cannot ask for 16 M instances or 3 GB of zeros.
inline ImportOptions resolved_limits(ImportOptions o, uint64_t input_bytes) {
  if (o.max_texels == 0) o.max_texels = std::max<uint64_t>(uint64_t(1) << 26, 64 * input_bytes);
  if (o.max_instances == 0) o.max_instances = std::max<uint64_t>(1000000, input_bytes / 4);
  if (o.max_elements == 0) o.max_elements = std::max<uint64_t>(uint64_t(1) << 26, input_bytes);
  return o;
}

}  // namespace meshmux
