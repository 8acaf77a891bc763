#pragma once
// Importers from recorded hand motion to tracks (see ../shared/data/README.md).
// Each maps to the 26 OpenXR joints, sets "source", "rate_hz" and "derived"
// (joints computed from others, comma separated) metadata, and throws InputError
// naming file and line on bad input.
#include "handsteady/track.hpp"

#include <filesystem>
#include <vector>

namespace hs {

// FPHA skeleton.txt (21 joints, mm, 30 Hz) -> right hand. Empty files give an empty track.
Track import_fpha_file(const std::filesystem::path& skeleton_txt);
// Every skeleton.txt under a directory tree (sorted by path), one track per take.
std::vector<Track> import_fpha_takes(const std::filesystem::path& dir);
// A file or a directory tree; takes are concatenated, each starting 1 s after the
// previous one ends, with one untracked row between them and a "take: <t0> <path>"
// metadata line each.
Track import_fpha(const std::filesystem::path& file_or_dir);

// HoloLens 2 / MRTK CSV (both hands).
Track import_mrtk(const std::filesystem::path& csv);

// ManipNet BVH: forward kinematics; fingertips extrapolated (documented in docs/IMPORTERS.md).
Track import_bvh(const std::filesystem::path& bvh);

// Concatenation used by directory imports (see import_fpha).
Track concatenate_takes(const std::vector<Track>& takes, const std::vector<std::string>& names, double gap_s = 1.0);

}  // namespace hs
