#include "diagnosis/refinement.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace pneumatic::diagnosis {

RefinedEffects ChooseRefinedEffects(const std::vector<CandidateResult>& ranking, const std::set<std::string>& refinable) {
  std::map<std::string, double> best_simple;  // each effect's best dIC among its simpler forms, by name
  std::set<std::string> explaining;           // the effects with a simpler form that explains
  for (const CandidateResult& result : ranking) {
    if (std::isnan(result.delta_ic)) continue;
    auto [best, inserted] = best_simple.try_emplace(result.effect, result.delta_ic);
    if (!inserted) best->second = std::min(best->second, result.delta_ic);
    if (result.explains) explaining.insert(result.effect);
  }
  RefinedEffects e;
  for (const auto& [effect, dic] : best_simple) {
    if (e.leader.empty() || dic < best_simple[e.leader]) e.leader = effect;
    if (refinable.count(effect) && (e.first.empty() || dic < best_simple[e.first])) e.first = effect;
  }
  for (const auto& [effect, dic] : best_simple) {
    if (effect != e.first && explaining.count(effect) && refinable.count(effect) &&
        (e.runner_up.empty() || dic < best_simple[e.runner_up])) {
      e.runner_up = effect;
    }
  }
  return e;
}

const CandidateResult* SettledBefore(const std::string& effect, const std::vector<CandidateResult>& ranking, const std::string& leader) {
  for (const CandidateResult& result : ranking) {
    if (!result.leaves_nothing_to_explain) continue;
    if (result.effect == effect ? result.refinement : effect != leader) return &result;
  }
  return nullptr;
}

}  // namespace pneumatic::diagnosis
