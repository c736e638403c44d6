// libFuzzer target: the gltf importer on arbitrary bytes (see fuzz_import.h).
#include "fuzz_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  meshmux::fuzz::import_bytes(data, size, "m.gltf");
  return 0;
}
