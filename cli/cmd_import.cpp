// handsteady import: recorded hand motion (FPHA, HoloLens 2 / MRTK, ManipNet BVH) -> track CSV.
#include "commands.hpp"

#include "handsteady/import.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <string>

namespace hs::cli {

namespace {

struct ImportArgs {
  std::string format;
  std::string in;
  std::string out;
  std::string hand;
};

void run_import(const ImportArgs& a) {
  Track track;
  if (a.format == "fpha") {
    if (!a.hand.empty()) throw InputError({"", 0, "--hand"}, "--hand applies to bvh only (FPHA is a right hand)");
    track = import_fpha(a.in);
  } else if (a.format == "mrtk") {
    if (!a.hand.empty()) throw InputError({"", 0, "--hand"}, "--hand applies to bvh only (MRTK files hold both hands)");
    track = import_mrtk(a.in);
  } else {  // bvh (CLI11 checks the choice)
    BvhImportOptions opt;
    if (!a.hand.empty()) opt.hand = parse_hand(a.hand);
    track = import_bvh(a.in, opt);
  }
  write_track_csv(track, std::filesystem::path(a.out));
  size_t n[2] = {0, 0};
  for (const auto& r : track.rows) ++n[static_cast<int>(r.hand)];
  std::printf("%s\n", fmt::format("wrote {}: {} left rows, {} right rows ({})", a.out, n[0], n[1],
                                  track.meta("source").value_or(a.format))
                          .c_str());
}

void setup_import(CLI::App& app) {
  auto args = std::make_shared<ImportArgs>();
  auto* cmd = app.add_subcommand("import", "Convert recorded hand motion to a HandSteady track CSV");
  cmd->footer(
      "Formats (details: docs/IMPORTERS.md):\n"
      "  fpha  FPHA skeleton.txt (21 joints, mm, 30 Hz, right hand). --in may be a file or a\n"
      "        directory: every skeleton.txt below it, sorted by path, concatenated 1 s apart\n"
      "        with an untracked row between takes and a 'take: <t0> <path>' metadata line each.\n"
      "  mrtk  HoloLens 2 MRTK CSV (Label,Time,Counter, 26 joints x 2 hands). Unsuffixed columns\n"
      "        are the right hand, '.1' the left; t = Time - first Time; rows whose Time does not\n"
      "        increase are dropped and counted in 'dropped_rows'.\n"
      "  bvh   ManipNet BVH (decimetres, 120 Hz): forward kinematics; fingertips, finger\n"
      "        metacarpals and palm derived. Hand from '_leftHand'/'_rightHand' in the file\n"
      "        name unless --hand is given.\n"
      "Output: metres, OpenXR axes (+Y up, -Z forward); derived joints are listed in the\n"
      "'derived' metadata line.\n"
      "Example: handsteady import --format fpha --in ../shared/data/fpha/Subject_1 --out s1.csv");
  cmd->add_option("--format,-f", args->format, "Input format")->required()->check(CLI::IsMember({"fpha", "mrtk", "bvh"}));
  cmd->add_option("--in,-i", args->in, "Input file (or directory for fpha)")->required()->check(CLI::ExistingPath);
  cmd->add_option("--out,-o", args->out, "Output track CSV")->required();
  cmd->add_option("--hand", args->hand, "bvh only: left|right, overrides the file name")
      ->check(CLI::IsMember({"left", "right"}));
  cmd->callback([args] { run_import(*args); });
}

const CommandRegistration register_import(&setup_import);

}  // namespace

}  // namespace hs::cli
