// libFuzzer target for the training config's JSON text (docs/TRAINING.md "Config file"):
// any byte string gives a TrainConfig or an hs::InputError naming the key; nothing else
// may come out of it (no other exception, crash, hang or leak). A config that reads must
// hold what training relies on. `base` chains need files, so only the text is fuzzed.
#include "train_config.hpp"

#include "handsteady/error.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hs::train::TrainConfig c;
  try {
    c = hs::train::parse_train_config(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json");
  } catch (const hs::InputError&) {
    return 0;
  }
  bool ok = !c.train_sources.empty() || c.synthetic_takes > 0;
  ok = ok && c.epochs > 0 && c.batch > 0 && !c.lr.empty() && c.sequence_length() >= c.model.window;
  ok = ok && !c.val_presets.empty() && c.augment.scale_min > 0 && c.augment.scale_max >= c.augment.scale_min;
  for (const auto& s : c.train_sources) ok = ok && s.weight > 0;
  for (const auto& m : c.mix) ok = ok && m.weight >= 0;
  if (!ok) __builtin_trap();
  (void)hs::train::learning_rate(c, c.epochs - 1);
  return 0;
}
