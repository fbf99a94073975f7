#include "cli/reproduce_command.h"

#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "reproductions/reproduce_hodgson2012.h"
#include "reproductions/reproduce_karpenko2006.h"
#include "reproductions/reproduce_laib2021.h"

namespace pneumatic::cli {
namespace {

int RunReproduce(const std::string& reproduce_name, const std::string& reproduce_out) {
  std::string error;
  nlohmann::json result =
      reproduce_name == "laib2021"       ? pneumatic::ReproduceLaib2021(PNEUMATIC_MODELS_DIR, reproduce_out, &error)
      : reproduce_name == "karpenko2006" ? pneumatic::ReproduceKarpenko2006(PNEUMATIC_MODELS_DIR, reproduce_out, &error)
                                         : pneumatic::ReproduceHodgson2012(PNEUMATIC_MODELS_DIR, reproduce_out, &error);
  if (result.is_null()) return Fail("reproduce " + reproduce_name + ": " + error);
  std::printf("%s\n", result.dump(2).c_str());
  return 0;
}

}  // namespace

Command AddReproduceCommand(CLI::App& app) {
  struct Arguments {
    std::string reproduce_name, reproduce_out;
  };
  auto arguments = std::make_shared<Arguments>();
  std::string &reproduce_name = arguments->reproduce_name, &reproduce_out = arguments->reproduce_out;
  CLI::App* reproduce = app.add_subcommand(
      "reproduce", "rerun a paper's experiment on its rig and print its headline figures next to the paper's (JSON)");
  reproduce->add_option("name", reproduce_name,
                        "the paper: karpenko2006 (paper 001's nonlinear PI on rig B), hodgson2012 (paper 002's sliding "
                        "controllers on rig A) or laib2021 (paper 003's averaged PWM model and sliding-mode controller "
                        "with observers on rig A)")
      ->required()
      ->check(CLI::IsMember({"karpenko2006", "hodgson2012", "laib2021"}));
  reproduce->add_option("--out", reproduce_out, "directory for the JSON, the logs and the comparison plots (PNG)");
  return {reproduce, [arguments] { return RunReproduce(arguments->reproduce_name, arguments->reproduce_out); }};
}

}  // namespace pneumatic::cli
