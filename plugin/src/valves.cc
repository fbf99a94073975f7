#include "valves.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <utility>

namespace pneumatic {
namespace {

bool HasDelays(const CylinderConfig& c) { return c.delay_open > 0 || c.delay_close > 0; }

// (start instant, value) pairs on [0, h]: the first starts at 0
using Timeline = InlineVector<std::pair<double, bool>, 32>;

// the on/off command of valve i (0..3: U1 P-supply, U2 P-exhaust, U3 N-supply, U4 N-exhaust) over the step
Timeline CommandTimeline(const CylinderConfig& c, int valve, const ValveInputs& in) {
  Timeline events;
  if (c.input == CommandInput::kValves) {
    events.push_back({0.0, in.command[valve] >= 0.5});
    return events;
  }
  // switched PWM of paper 003 eqs. (12)-(13): mode 6 (U1, U4) for u >= 0, mode 7 (U2, U3) for u < 0,
  // on for |u| of each carrier period, centred on the period's middle or from its start (pwm_alignment)
  double duty = std::clamp(in.command[0], -1.0, 1.0);
  bool active = duty >= 0 ? (valve == 0 || valve == 3) : (valve == 1 || valve == 2);
  double on_fraction = std::fabs(duty);
  if (!active || on_fraction == 0 || on_fraction == 1) {
    events.push_back({0.0, active && on_fraction == 1});
    return events;
  }
  double period = 1 / c.pwm_frequency;
  double t0 = in.time, t1 = in.time + in.step;
  double k = std::floor(t0 / period);
  double offset = c.pwm_alignment == PwmAlignment::kCenter ? (1 - on_fraction) * period / 2 : 0;
  auto push = [&](double tau, bool on) {
    if (events.empty() || events.back().second != on) events.push_back({tau, on});
  };
  for (; k * period < t1; k += 1) {
    double on_start = k * period + offset, on_end = on_start + on_fraction * period;
    if (on_start >= t1) break;
    push(std::max(on_start - t0, 0.0), on_start <= t0 ? t0 < on_end : true);
    if (on_end > t0 && on_end < t1) push(on_end - t0, false);
  }
  if (events.empty() || events.front().first > 0) events.insert_front({0.0, false});
  return events;
}

// armature of an on/off valve: rises at 1/(2 delay_open) while commanded open, falls at
// 1/(2 delay_close) while commanded closed; the port passes flow while it is beyond 1/2,
// so an isolated switch takes effect exactly delay_open (delay_close) later
struct Armature {
  const CylinderConfig& c;
  double position;  // [0, 1]

  // advances over `duration` with command `on`; returns the instant (from the segment start)
  // at which the port's state flips, or -1
  double Advance(bool on, double duration) {
    double delay = on ? c.delay_open : c.delay_close;
    double target = on ? 1.0 : 0.0;
    bool open_before = on ? position >= 0.5 : position > 0.5;
    double flip = -1;
    if (delay <= 0) {
      position = target;
      flip = open_before != on ? 0.0 : -1;
      return flip;
    }
    double rate = 0.5 / delay;
    double crossing = std::fabs(0.5 - position) / rate;
    if (open_before != on && crossing <= duration) flip = crossing;
    double moved = rate * duration;
    position = on ? std::min(position + moved, 1.0) : std::max(position - moved, 0.0);
    return flip;
  }
};

// whether valve i passes flow over the step, as a timeline; also the armature at the end
Timeline OpenTimeline(const CylinderConfig& c, int valve, const ValveInputs& in, double* armature_end) {
  Timeline command = CommandTimeline(c, valve, in);
  if (!HasDelays(c)) {
    if (armature_end) *armature_end = command.back().second ? 1.0 : 0.0;
    return command;
  }
  Armature armature{c, std::clamp(in.state[valve], 0.0, 1.0)};
  bool open = command.front().second ? armature.position >= 0.5 : armature.position > 0.5;
  Timeline result;
  result.push_back({0.0, open});
  for (int s = 0; s < command.size(); ++s) {
    double start = command[s].first;
    double end = s + 1 < command.size() ? command[s + 1].first : in.step;
    double flip = armature.Advance(command[s].second, end - start);
    if (flip >= 0) {
      open = command[s].second;
      if (start + flip <= 0) {
        result.front().second = open;
      } else {
        result.push_back({start + flip, open});
      }
    }
  }
  if (armature_end) *armature_end = armature.position;
  return result;
}

bool ValueAt(const Timeline& t, double tau) {
  bool value = t.front().second;
  for (const auto& [start, v] : t) {
    if (start <= tau) value = v;
  }
  return value;
}

}  // namespace

double OnOffCapacity(const ChamberConfig& chamber) {
  return chamber.flow == FlowLaw::kIso6358 ? chamber.sonic_conductance : chamber.port_area;
}

double SpoolOpening(const CylinderConfig& c, double spool_position) {
  // deadband: no flow while |x_v| is within deadband * (k_v u_max) of the centre
  double half_width = c.deadband * c.spool_gain * c.u_max;
  double open = std::max(std::fabs(spool_position) - half_width, 0.0);
  return spool_position >= 0 ? open : -open;
}

bool ValvesHaveState(const CylinderConfig& c) {
  if (c.valve == ValveKind::kOnOff) return HasDelays(c);
  return c.spool_time_constant > 0;  // the 5/3 valve's spool, the per-chamber valves' lagged voltages
}

int DelayChannels(const CylinderConfig& c) {
  if (c.valve == ValveKind::kOnOff || !(c.CommandDeadTime() > 0)) return 0;
  return c.valve == ValveKind::kProportional53 ? 1 : 2;
}

ValveSignal::ValveSignal(double command, double dead_time, const double delay[2], double lag, double lag_start,
                         double gain)
    : u_(command), dead_time_(dead_time), lag_(lag), gain_(gain) {
  if (dead_time_ > 0) e1_ = delay[0] - command, e2_ = delay[1];
  sigma0_ = lag_ > 0 ? lag_start - gain * command : 0.0;
}

void ValveSignal::DelayState(double t, double out[2]) const {
  if (!(dead_time_ > 0)) {
    out[0] = u_, out[1] = 0;
    return;
  }
  // e(t) = exp(A t) e(0), the closed form of valves.h (project's own realisation of the (1,2) Pade approximant)
  const double theta = t / dead_time_, decay = std::exp(-2 * theta);
  const double c = std::cos(std::sqrt(2.0) * theta), s = std::sin(std::sqrt(2.0) * theta) / std::sqrt(2.0);
  out[0] = u_ + decay * (c * e1_ + s * (4 * e1_ + 3 * e2_));
  out[1] = decay * (c * e2_ + s * (-6 * e1_ - 4 * e2_));
}

double ValveSignal::Delayed(double t) const {
  double x[2];
  DelayState(t, x);
  return x[0];
}

double ValveSignal::At(double t) const {
  if (!(lag_ > 0)) return gain_ * Delayed(t);
  const double target = gain_ * u_, fade = std::exp(-t / lag_);
  // paper 001 eq. (1), the first-order lag, solved exactly for a held input
  if (!(dead_time_ > 0)) return target + sigma0_ * fade;
  // driven by the delayed command u + e1(t), e1(t) = Re[K exp(lambda t)] (valves.h)
  const std::complex<double> lambda(-2 / dead_time_, std::sqrt(2.0) / dead_time_);
  const std::complex<double> k(e1_, -(4 * e1_ + 3 * e2_) / std::sqrt(2.0));
  const std::complex<double> forced = k * (std::exp(lambda * t) - fade) / (1.0 + lambda * lag_);
  return target + sigma0_ * fade + gain_ * forced.real();
}

ValveSignal ProportionalSignal(const CylinderConfig& c, int channel, const ValveInputs& in) {
  // 5/3: the valve's input saturates at +-u_max before the delay and the spool (paper 001 eq. 1)
  bool five_three = c.valve == ValveKind::kProportional53;
  double u = five_three ? std::clamp(in.command[0], -c.u_max, c.u_max) : in.command[channel];
  return ValveSignal(u, c.CommandDeadTime(), in.delay[channel], c.spool_time_constant, in.state[channel],
                     five_three ? c.spool_gain : 1.0);
}

double ValveStateAtEnd(const CylinderConfig& c, int valve, const ValveInputs& in) {
  if (c.valve != ValveKind::kOnOff && (c.CommandDeadTime() > 0 || c.valve == ValveKind::kProportionalPerChamber)) {
    return ProportionalSignal(c, valve, in).At(in.step);
  }
  if (c.valve == ValveKind::kProportional53) {
    // spool first-order lag, paper 001 eq. (1), solved exactly over the held command
    double target = c.spool_gain * std::clamp(in.command[0], -c.u_max, c.u_max);
    if (c.spool_time_constant <= 0) return target;
    return target + (in.state[0] - target) * std::exp(-in.step / c.spool_time_constant);
  }
  double end = 0;
  OpenTimeline(c, valve, in, &end);
  return end;
}

PortSchedule::PortSchedule(const CylinderConfig& c, int chamber, const ValveInputs& in)
    : config_(&c), chamber_(chamber) {
  const ChamberConfig& k = c.chamber[chamber];
  switch (c.valve) {
    case ValveKind::kProportional53:
      spool_ = true;
      if (c.CommandDeadTime() > 0) {
        signal_driven_ = true;
        signal_ = ProportionalSignal(c, 0, in);
        return;
      }
      spool_target_ = c.spool_gain * std::clamp(in.command[0], -c.u_max, c.u_max);
      spool_start_ = c.spool_time_constant > 0 ? in.state[0] : spool_target_;
      return;
    case ValveKind::kProportionalPerChamber:
      if (c.CommandDeadTime() > 0 || c.spool_time_constant > 0) {
        signal_driven_ = true;
        signal_ = ProportionalSignal(c, chamber, in);
        return;
      }
      segments_.push_back(ProportionalValveAreas(k, in.command[chamber], c.deadband_voltage));
      return;
    case ValveKind::kOnOff:
      break;
  }
  double capacity = OnOffCapacity(k);
  if (c.input == CommandInput::kPwm && c.pwm_frequency == 0) {
    // averaged model, paper 003 eq. (14): each valve open for the fraction |u| of the time
    double duty = std::clamp(in.command[0], -1.0, 1.0);
    double push = std::max(duty, 0.0), pull = std::max(-duty, 0.0);
    // chamber P fills in mode 6 (u > 0) and vents in mode 7; chamber N the reverse
    segments_.push_back(chamber == 0 ? PortOpenings{push * capacity, pull * capacity}
                                     : PortOpenings{pull * capacity, push * capacity});
    return;
  }
  Timeline supply = OpenTimeline(c, 2 * chamber, in, nullptr);
  Timeline exhaust = OpenTimeline(c, 2 * chamber + 1, in, nullptr);
  InlineVector<double, 64> instants;
  for (const auto& e : supply) instants.push_back(e.first);
  for (const auto& e : exhaust) instants.push_back(e.first);
  std::sort(instants.begin(), instants.end());
  instants.resize(static_cast<int>(std::unique(instants.begin(), instants.end()) - instants.begin()));
  for (double t : instants) {
    if (t > 0 && t < in.step) breakpoints_.push_back(t);
  }
  segments_.push_back({ValueAt(supply, 0) ? capacity : 0, ValueAt(exhaust, 0) ? capacity : 0});
  for (double t : breakpoints_) {
    segments_.push_back({ValueAt(supply, t) ? capacity : 0, ValueAt(exhaust, t) ? capacity : 0});
  }
}

PortOpenings PortSchedule::Varying(double tau) const {
  if (signal_driven_ && !spool_) {
    // paper 000 eq. (3) at the delayed and lagged voltage
    return ProportionalValveAreas(config_->chamber[chamber_], signal_.At(tau), config_->deadband_voltage);
  }
  if (spool_) {
    const CylinderConfig& c = *config_;
    double spool = spool_target_;
    if (signal_driven_) {
      spool = signal_.At(tau);
    } else if (c.spool_time_constant > 0) {
      spool += (spool_start_ - spool_target_) * std::exp(-tau / c.spool_time_constant);
    }
    // x_v >= 0: supply -> P and N -> exhaust; x_v < 0 the reverse (docs/rigs.md rig B)
    double area = c.orifice_gradient * SpoolOpening(c, spool);
    double toward_p = std::max(area, 0.0), toward_n = std::max(-area, 0.0);
    return chamber_ == 0 ? PortOpenings{toward_p, toward_n} : PortOpenings{toward_n, toward_p};
  }
  int segment = 0;
  while (segment < breakpoints_.size() && breakpoints_[segment] <= tau) ++segment;
  return segments_[segment];
}

SwitchInstants MergedBreakpoints(const PortSchedule& a, const PortSchedule& b) {
  SwitchInstants merged;
  const SwitchInstants &x = a.breakpoints(), &y = b.breakpoints();
  int i = 0, j = 0;
  while (i < x.size() || j < y.size()) {
    double next = j >= y.size() || (i < x.size() && x[i] <= y[j]) ? x[i++] : y[j++];
    if (merged.empty() || merged.back() < next) merged.push_back(next);
  }
  return merged;
}

}  // namespace pneumatic
