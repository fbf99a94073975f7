#include "cli/info_command.h"

#include <cstdio>
#include <memory>
#include <string>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"
#include "simulation/controller_config.h"

namespace pneumatic::cli {
namespace {

int RunInfo(const std::string& model_path) {
  AttachedModel model;
  if (std::string e = Load(model_path, &model); !e.empty()) return Fail(e);
  const mjModel* m = model.model;
  std::printf("%s: timestep %g s, %d actuators, %zu pneumatic cylinders\n", model_path.c_str(), m->opt.timestep,
              m->nu, pneumatic::Cylinders(m).size());
  for (const auto& c : pneumatic::Cylinders(m)) {
    std::printf("cylinder %s: p_supply %g Pa, p_exhaust %g Pa, p_atm %g Pa\n  commands:", c.name.c_str(), c.p_supply,
                c.p_exhaust, c.p_atm);
    for (const auto& [signal, id] : c.command_actuators) std::printf(" %s.%s", c.name.c_str(), signal.c_str());
    std::printf("\n  measured: %s.p_P %s.p_N %s.x %s.v %s.p_S\n", c.name.c_str(), c.name.c_str(), c.name.c_str(),
                c.name.c_str(), c.name.c_str());
  }
  // the controllers' configurations the model carries (pneumo rollout --controller NAME uses them)
  const std::string prefix = pneumatic::kModelControllerConfigPrefix;
  for (int i = 0; i < m->ntext; ++i) {
    const std::string name = m->names + m->name_textadr[i];
    if (name.rfind(prefix, 0) != 0) continue;
    std::printf("controller %s: configuration carried in <text name=\"%s\">: %s\n", name.substr(prefix.size()).c_str(),
                name.c_str(), m->text_data + m->text_adr[i]);
  }
  return 0;
}

}  // namespace

Command AddInfoCommand(CLI::App& app) {
  auto model_path = std::make_shared<std::string>();
  CLI::App* info = app.add_subcommand("info", "list a model's cylinders and their log signals");
  info->add_option("model", *model_path, "MJCF model")->required();
  return {info, [model_path] { return RunInfo(*model_path); }};
}

}  // namespace pneumatic::cli
