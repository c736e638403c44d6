// Uploads as users make them, for the tests: a textured COLLADA quad, a simulator model
// database's folder layout, and .zip archives written with libzip.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace meshmux::testing {

// A 2×1 RGB PNG (red, blue).
extern const std::vector<uint8_t> kPng;

// A textured quad in COLLADA 1.4.1 whose one image is `image` (as written in <init_from>).
std::string textured_dae(const std::string& image);

// The standard layout of a simulator's model database, under `root`: model.config,
// meshes/x.dae naming ../materials/textures/x.png, and that PNG.
void write_database_model(const std::string& root);

struct ZipMember {
  std::string name;
  std::string data;
  uint32_t unix_mode = 0;  // 0: a plain file (libzip's default attributes)
};

// Writes a .zip with libzip (fails the current test on error).
void write_zip(const std::string& path, const std::vector<ZipMember>& members);

// Every regular file under `root` packed into a .zip, with names relative to `root`.
void zip_folder(const std::string& root, const std::string& path);

}  // namespace meshmux::testing
