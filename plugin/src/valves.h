// Valves: the openings of a chamber's supply and exhaust ports over one step.
//
// Openings are in the units of the chamber's flow law (C_val in kg/(s Pa) for
// iso6358, area in m^2 for sanville and thin plate). Within a step, commands
// are held (zero-order hold); valve states (spool position, on/off armature)
// move as closed-form functions of time, so the openings are known exactly at
// any instant of the step and the chamber integrator can split the step at
// the instants where they jump.
#ifndef PNEUMATIC_VALVES_H_
#define PNEUMATIC_VALVES_H_

#include <cmath>

#include "config.h"

namespace pneumatic {

// A short list stored inline, so that a step allocates nothing on the heap. It holds
// at most N items; a push beyond that replaces the last item (Attach refuses the
// configurations that could get there: more than kMaxPwmPeriodsPerStep carrier periods).
template <typename T, int N>
class InlineVector {
 public:
  InlineVector() {}  // items are left uninitialized: only the first size() are ever read
  void push_back(const T& item) { items_[size_ < N ? size_++ : N - 1] = item; }
  void insert_front(const T& item) {
    if (size_ < N) ++size_;
    for (int i = size_ - 1; i > 0; --i) items_[i] = items_[i - 1];
    items_[0] = item;
  }
  void resize(int n) { size_ = n; }
  int size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T& operator[](int i) { return items_[i]; }
  const T& operator[](int i) const { return items_[i]; }
  T* begin() { return items_; }
  T* end() { return items_ + size_; }
  const T* begin() const { return items_; }
  const T* end() const { return items_ + size_; }
  const T& front() const { return items_[0]; }
  T& front() { return items_[0]; }
  const T& back() const { return items_[size_ - 1]; }

 private:
  union {  // a union member is not constructed: no cost for the unused capacity
    T items_[N];
  };
  int size_ = 0;
};

// switched PWM: at most this many carrier periods may fall in one MuJoCo step
constexpr double kMaxPwmPeriodsPerStep = 8;
// instants within one step where a chamber's openings jump
using SwitchInstants = InlineVector<double, 64>;

struct PortOpenings {
  double supply = 0;   // port between supply and chamber
  double exhaust = 0;  // port between chamber and exhaust
};

// commands and valve states of one cylinder at the start of a step
struct ValveInputs {
  double time = 0;         // s, d->time
  double step = 0;         // s, the MuJoCo timestep h
  // onoff/valves: u1..u4; onoff/pwm: [0] = duty; 5/3: [0] = u (V); per chamber: [0] = uP, [1] = uN (V)
  double command[4] = {0, 0, 0, 0};
  // onoff with delays: armature positions of valves 1..4 in [0, 1]; 5/3 with a lag: [0] = spool x_v (m);
  // per chamber with a lag: [0], [1] = lagged voltage of chamber P's, N's valve (V)
  double state[4] = {0, 0, 0, 0};
  // spool_dead_time > 0: the delay line of each command channel (5/3: [0]; per chamber: [0] = uP, [1] = uN),
  // [x1, x2] of ValveSignal, both in V
  double delay[2][2] = {{0, 0}, {0, 0}};
};

// The signal that drives a proportional valve over one step (commands held): the command u, delayed by
// the dead time T (spool_dead_time > 0), then through the spool's first-order lag tau (spool_time_constant
// > 0), times a gain (5/3: k_v, the output a spool position in m; per chamber: 1, a voltage in V).
//
// Dead time: the (1,2) Pade approximant of exp(-s T) (numerator degree 1, denominator 2; the general
// (p,q) Pade approximant of the exponential, e.g. Golub and Van Loan, Matrix Computations, 3rd ed., Sec. 11.3,
// with x = -s T):
//   G(s) = (1 - s T/3) / (1 + 2 s T/3 + (s T)^2 / 6),   G(0) = 1, G = exp(-s T) + O((s T)^4)
// It is strictly proper: a step of the command starts to pass only after a while (the (2,2) approximant
// (1 - s T/2 + (s T)^2/12) / (1 + s T/2 + (s T)^2/12), e.g. Franklin, Powell and Emami-Naeini, Feedback
// Control of Dynamic Systems, is all-pass: its step response jumps to 1 at once, then swings to -0.4, which
// would open a valve at once instead of after T). The project's own realisation, in V:
//   dx1/dt = (2 (x1 - u) + 3 x2) / T,   dx2/dt = (-6 (x1 - u) - 6 x2) / T,   delayed command y = x1
// (x1/u = G(s)); at rest x1 = u and x2 = 0, so act = 0 is the line at rest on a 0 V command (what
// mj_resetData's ctrl = 0 gives). With u held, e = x - (u, 0) follows de/dt = A e exactly:
//   e(t) = exp(-2 t/T) [cos(sqrt2 t/T) I + sin(sqrt2 t/T)/sqrt2 [[4, 3], [-6, -4]]] e(0)
// (the exponential of a 2x2 matrix with eigenvalues (-2 +- i sqrt2)/T, by Cayley-Hamilton).
// Lag: ds/dt = (gain y - s) / tau (paper 001 eq. 1), solved exactly with y(t) = u + e1(t) above:
//   s(t) = gain u + exp(-t/tau) (s0 - gain u) + gain Re[K (exp(lambda t) - exp(-t/tau)) / (1 + lambda tau)]
// with lambda = (-2 + i sqrt2)/T and e1(t) = Re[K exp(lambda t)], K = e1 - i (4 e1 + 3 e2)/sqrt2;
// without a dead time s(t) = gain u + (s0 - gain u) exp(-t/tau) (paper 001 eq. 1 solved exactly).
class ValveSignal {
 public:
  ValveSignal() {}
  // command u (V, held), dead time T (s; 0: none) and the delay line's state [x1, x2] at the start, lag
  // tau (s; 0: none) and the lag's state at the start (gain units), gain
  ValveSignal(double command, double dead_time, const double delay[2], double lag, double lag_start, double gain);
  // the delayed command y(t) (V): the command itself without a dead time
  double Delayed(double t) const;
  // the delay line's state [x1, x2] at t (V)
  void DelayState(double t, double out[2]) const;
  // what drives the ports at t: the lag's state with a lag, else gain times the delayed command
  double At(double t) const;

 private:
  double u_ = 0, dead_time_ = 0, e1_ = 0, e2_ = 0, lag_ = 0, sigma0_ = 0, gain_ = 1;
};

// the signal of command channel `channel` (5/3: 0; per chamber: 0 = P, 1 = N) over the step
ValveSignal ProportionalSignal(const CylinderConfig& c, int channel, const ValveInputs& in);

// full-open capacity of one on/off valve port in flow-law units, per chamber
double OnOffCapacity(const ChamberConfig& chamber);

// smooth max(y, 0) over a scale `unit`: paper 000 Section II.A.3's smax(y) = (sqrt(y^2 + 1) + y) / 2 taken
// on y / unit (the paper's mm^2) and scaled back, unit smax(y / unit) = (sqrt(y^2 + unit^2) + y) / 2
inline double Smax(double y, double unit) { return (std::sqrt(y * y + unit * unit) + y) / 2; }

// paper 000 eq. (3): supply and exhaust areas (m^2) of a chamber's own valve at command u (V); a
// deadband (deadband_voltage, V) moves the supply seal up to U_c + deadband and the exhaust seal down
// to U_r - deadband (the project's own form of the spool deadband of paper 001 for this valve). Inline:
// every step of every such chamber takes it.
inline PortOpenings ProportionalValveAreas(const ChamberConfig& k, double u, double deadband = 0) {
  // areas scaled by area_smoothing (the paper's mm^2) inside smax
  double unit = k.area_smoothing;
  double supply_seal = k.u_supply_seal, exhaust_seal = k.u_exhaust_seal;
  if (deadband > 0) supply_seal += deadband, exhaust_seal -= deadband;
  PortOpenings a;
  a.supply = k.leak_area_supply + Smax((u - supply_seal) * k.area_gain - k.leak_area_supply, unit);
  a.exhaust = k.leak_area_exhaust + Smax((exhaust_seal - u) * k.area_gain - k.leak_area_exhaust, unit);
  return a;
}

// effective spool opening (m) after the deadband; paper 001, docs/rigs.md rig B
double SpoolOpening(const CylinderConfig& c, double spool_position);

// The openings of one chamber's ports on [0, h], piecewise in time.
class PortSchedule {
 public:
  PortSchedule(const CylinderConfig& c, int chamber, const ValveInputs& in);
  PortOpenings At(double tau) const {
    // the common case inline: openings held over the whole step
    return signal_driven_ || spool_ || !breakpoints_.empty() ? Varying(tau) : segments_[0];
  }
  // instants in (0, h) where the openings jump, increasing
  const SwitchInstants& breakpoints() const { return breakpoints_; }

 private:
  // At for openings that change over the step (a spool, a lag or a dead time, switching valves)
  PortOpenings Varying(double tau) const;

  const CylinderConfig* config_;
  int chamber_;
  bool spool_ = false;                  // 5/3 valve: openings follow the spool
  double spool_start_ = 0, spool_target_ = 0;
  // 5/3 valve with a dead time (the spool), per-chamber valve with a lag or a dead time (the voltage):
  // the openings follow signal_
  bool signal_driven_ = false;
  ValveSignal signal_;
  SwitchInstants breakpoints_;                  // segment k starts at breakpoints_[k-1] (0 for k = 0)
  InlineVector<PortOpenings, 65> segments_;  // openings on each segment
};

// the breakpoints of two schedules, merged, increasing, without repeats
SwitchInstants MergedBreakpoints(const PortSchedule& a, const PortSchedule& b);

// state of valve actuators at the end of the step (the value their act must reach)
// onoff: armature of valve i (0..3); 5/3: spool position (m); per chamber: lagged voltage of valve i (V)
double ValveStateAtEnd(const CylinderConfig& c, int valve, const ValveInputs& in);

// true if the cylinder's valves carry state in d->act (spool lag, on/off delays)
bool ValvesHaveState(const CylinderConfig& c);

// number of command channels with a dead-time delay line: 1 (5/3), 2 (per chamber) with spool_dead_time
// > 0, else 0
int DelayChannels(const CylinderConfig& c);

}  // namespace pneumatic

#endif  // PNEUMATIC_VALVES_H_
