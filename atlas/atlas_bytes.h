// The atlas within its bytes bound. Charts keep their sources' native texel density
// (atlas/atlas.h), and what bounds the atlas is bytes, not texels: its images, encoded as the
// texture levels' top level will be (image/encode.h: JPEG at the levels' quality, PNG for a
// base colour with alpha), may cost at most kAtlasBytesBound × the encoded bytes of the source
// images they replace, plus kAtlasImageAllowance per atlas image (a container, the flat blocks
// and the dilated margins cost about that much even over a few tiny sources). Over it, the
// density shrinks by the excess (JPEG bytes grow about linearly with the texels that hold
// content), never below kAtlasMinDensity, and the atlas is built again, at most
// kAtlasBytesRounds times. Where the floor stops it, density wins and the report says by how
// much the bound is missed (AtlasReport::atlas_bytes against source_bytes).
// The last round's encodings stay in the atlas images' `encoded` (with mime_type): they are the
// texture levels' top level (TextureLevelOptions::top_from_encoded), not encoded again.
// Cost: one encode of the atlas's images per round, plus each rebuild's packing and baking (the
// charts are segmented and flattened once and handed on: AtlasMemo).
#pragma once

#include "atlas/atlas.h"
#include "core/encode_counts.h"

namespace meshmux {

constexpr double kAtlasBytesBound = 1.1;
constexpr double kAtlasImageAllowance = 32e3;  // bytes per atlas image
constexpr double kAtlasMinDensity = 0.25;      // texels per source texel (half the resolution)
constexpr int kAtlasBytesRounds = 3;

// build_atlas under the bound above; `jpeg_quality` is the texture levels' top-level quality.
// The report is the last build's, with atlas_bytes, source_bytes and bytes_rounds filled. The
// encodings handed on are files written: counted in `counts` (when given); earlier rounds'
// are measures.
Result<Scene> build_atlas_within_bytes(const Scene& scene, const AtlasOptions& options,
                                       int jpeg_quality, AtlasReport* report, Warnings* warnings,
                                       EncodeCounts* counts = nullptr);

}  // namespace meshmux
