// pneumo: the command line of the pneumatic extension for MuJoCo 2.2.
//
//   pneumo rollout MODEL.xml --commands LOG.csv --out OUT.csv   replay a log open loop
//   pneumo rollout MODEL.xml --duration 2 --set cyl.u=2.5 --out OUT.csv
//   pneumo rollout MODEL.xml --controller pid --reference GESTURE.csv --duration 10 --out OUT.csv   closed loop
//   pneumo generate MODEL.xml --duration 100 --seed 1 --out LOG.csv   closed-loop identification log (rig C)
//   pneumo identify MODEL.xml LOG.csv --out PARAMS.json --heldout LOG2.csv   fit paper 000's model and physical parameters
//   pneumo render MODEL.xml --out frame.png [--log LOG.csv --time T]   a picture, off screen (OSMesa)
//   pneumo reproduce karpenko2006|hodgson2012|laib2021 [--out DIR]                  a paper's experiment rerun in simulation
//   pneumo study PLAN.json --out DIR [--jobs N]                 a parameter study (docs/study.md)
//   pneumo info MODEL.xml                                       cylinders and their signals
//   pneumo params [--markdown]                                  the MJCF parameter table
//
// main builds the app from the verbs, one file each (<verb>_command.cc: its options and what runs
// it, on the library's folders), and runs the verb chosen.
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/command_support.h"
#include "cli/diagnose_command.h"
#include "cli/generate_command.h"
#include "cli/identify_command.h"
#include "cli/info_command.h"
#include "cli/params_command.h"
#include "cli/render_command.h"
#include "cli/reproduce_command.h"
#include "cli/rollout_command.h"
#include "cli/study_command.h"

int main(int argc, char** argv) {
  CLI::App app{"pneumo: pneumatic actuators for MuJoCo 2.2"};
  app.require_subcommand(1);
  app.failure_message(CLI::FailureMessage::help);

  namespace cli = pneumatic::cli;
  // the verbs, in the order the help lists them
  const std::vector<cli::Command> commands = {cli::AddRolloutCommand(app),   cli::AddGenerateCommand(app),
                                              cli::AddIdentifyCommand(app),  cli::AddRenderCommand(app),
                                              cli::AddReproduceCommand(app), cli::AddDiagnoseCommand(app),
                                              cli::AddStudyCommand(app),
                                              cli::AddInfoCommand(app),      cli::AddParamsCommand(app)};

  CLI11_PARSE(app, argc, argv);
  for (const cli::Command& command : commands) {
    if (*command.app) return command.run();
  }
  return 2;
}
