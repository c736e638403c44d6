// An upload: what a user hands meshmux — a folder, a .zip archive, or one model file — and
// the model file found inside it. The upload's root bounds every read the importers make
// (ImportOptions::root): a COLLADA file in meshes/ may read ../materials/textures/x.png when
// both lie inside the uploaded folder or archive, and nothing outside it.
//
// Contract:
// - A folder: its root is the folder (links resolved). The model file is `main` when given
//   (relative to the root, and inside it), else the one .gltf/.glb/.dae (any letter case)
//   nearest the root; hidden entries, __MACOSX and "._*" files are not candidates. Several at
//   the nearest depth: an error listing them (up to 8) and naming --main. None: an error.
// - A .zip (by extension or by its "PK\3\4" magic): unpacked with libzip into `scratch`, a
//   folder this call creates (mode 0700, must not exist) and the Upload removes when it is
//   destroyed; then as a folder. Before a byte is written every member is checked, and the
//   archive is refused, naming the member, when one has an absolute path or a drive letter, a
//   ".." component, is a symbolic link, device, FIFO or socket, is encrypted, or appears
//   twice; when there are more than `max_members` members; or when the sizes it declares, or
//   the bytes it really inflates to, exceed `max_unpacked_bytes` (a zip bomb is one line, not
//   a full disk). Files are created O_EXCL|O_NOFOLLOW below `scratch` only.
// - A lone model file: its root is `root` when given (which must contain the file), else the
//   file's folder.
// Errors (kInput) are one line naming the upload: "upload: models.zip: member '../x.png'
// leaves the archive; refused". Complexity: O(entries walked + bytes unpacked).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"

namespace meshmux {

struct UploadOptions {
  std::string main;  // --main: the model file, relative to the upload's root ("" = find it)
  std::string root;  // --root: for a lone model file, the folder that bounds its reads
                     // ("" = the file's folder); ignored for folders and archives
  uint64_t max_unpacked_bytes = 0;  // .zip: bytes unpacked in all; 0 = max(512 MiB, 64 × the
                                    // archive's size)
  uint64_t max_members = 20000;     // .zip: members (files and folders) in all
  uint64_t max_walk_entries = 200000;  // folder: entries looked at when finding the model
};

// A found upload. Move-only: an unpacked archive's folder is removed by the destructor.
class Upload {
 public:
  Upload() = default;
  Upload(Upload&& o) noexcept;
  Upload& operator=(Upload&& o) noexcept;
  Upload(const Upload&) = delete;
  Upload& operator=(const Upload&) = delete;
  ~Upload();

  const std::string& root() const { return root_; }    // resolved folder bounding every read
  const std::string& model() const { return model_; }  // the model file, inside root()
  // The model file as the user knows it: "upload.zip:meshes/a.dae", "folder/meshes/a.dae".
  const std::string& display() const { return display_; }
  bool unpacked() const { return !scratch_.empty(); }  // it came from an archive

 private:
  void remove_scratch();
  friend Result<Upload> open_upload(const std::string&, const UploadOptions&,
                                    const std::string&);
  std::string root_, model_, display_, scratch_;
};

// Opens the upload at `path` (a folder, a .zip or a model file). `scratch` is where an archive
// is unpacked (a path that does not exist yet, on a disk with room; unused otherwise).
Result<Upload> open_upload(const std::string& path, const UploadOptions& options,
                           const std::string& scratch);

// The files below `root` whose name is `name` (compared without letter case), at most
// `max_entries` entries looked at, hidden folders skipped, links not followed; sorted. Used to
// find a texture an author's path no longer reaches (an absolute path from their machine, a
// renamed folder, a model database whose .dae names a bare file in materials/textures/).
std::vector<std::string> find_by_file_name(const std::string& root, const std::string& name,
                                           uint64_t max_entries = 200000);

}  // namespace meshmux
