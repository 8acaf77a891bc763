// handsteady train --config FILE.json --out model.hsm [--resume ckpt] [--epochs N] [--threads N]
// Compiled into the CLI only when libtorch is found (hs_train exists: cli/CMakeLists.txt).
#include "commands.hpp"

#include "trainer.hpp"

#include <iostream>
#include <memory>
#include <string>

namespace {

struct TrainArgs {
  std::string config, out, resume;
  int epochs = 0, threads = 0;
  bool quiet = false;
};

void setup(CLI::App& app) {
  auto args = std::make_shared<TrainArgs>();
  auto* cmd = app.add_subcommand("train", "Train a Multi-STGAE model with libtorch (docs/TRAINING.md)");
  cmd->add_option("--config", args->config, "Training configuration (JSON)")->required();
  cmd->add_option("--out", args->out, "Best model on validation (.hsm); the checkpoint is <out>.ckpt")->required();
  cmd->add_option("--resume", args->resume, "Continue from a checkpoint written by an earlier run");
  cmd->add_option("--epochs", args->epochs, "Override train.epochs")->check(CLI::Range(1, 100000));
  cmd->add_option("--threads", args->threads, "Override train.threads (libtorch intra-op threads)")->check(CLI::Range(1, 256));
  cmd->add_flag("--quiet", args->quiet, "No progress bar");
  cmd->callback([args] {
    const hs::train::TrainConfig config = hs::train::read_train_config(args->config);
    hs::train::TrainOptions opt;
    opt.out = args->out;
    if (!args->resume.empty()) opt.resume = args->resume;
    if (args->epochs > 0) opt.epochs = args->epochs;
    if (args->threads > 0) opt.threads = args->threads;
    opt.progress = !args->quiet;
    hs::train::train_stgae(config, opt, std::cout);
  });
}

const hs::cli::CommandRegistration register_train(&setup);

}  // namespace
