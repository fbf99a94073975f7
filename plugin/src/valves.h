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
  // onoff with delays: armature positions of valves 1..4 in [0, 1]; 5/3 with a lag: [0] = spool x_v (m)
  double state[4] = {0, 0, 0, 0};
};

// full-open capacity of one on/off valve port in flow-law units, per chamber
double OnOffCapacity(const ChamberConfig& chamber);

// paper 000 eq. (3): supply and exhaust areas (m^2) of a chamber's own valve at command u (V); a
// deadband (deadband_voltage, V) moves the supply seal up to U_c + deadband and the exhaust seal down
// to U_r - deadband
PortOpenings ProportionalValveAreas(const ChamberConfig& chamber, double u, double deadband = 0);

// effective spool opening (m) after the deadband; paper 001, rigs.md rig B
double SpoolOpening(const CylinderConfig& c, double spool_position);

// The openings of one chamber's ports on [0, h], piecewise in time.
class PortSchedule {
 public:
  PortSchedule(const CylinderConfig& c, int chamber, const ValveInputs& in);
  PortOpenings At(double tau) const;
  // instants in (0, h) where the openings jump, increasing
  const SwitchInstants& breakpoints() const { return breakpoints_; }

 private:
  const CylinderConfig* config_;
  int chamber_;
  bool spool_ = false;                  // 5/3 valve: openings follow the spool
  double spool_start_ = 0, spool_target_ = 0;
  SwitchInstants breakpoints_;                  // segment k starts at breakpoints_[k-1] (0 for k = 0)
  InlineVector<PortOpenings, 65> segments_;  // openings on each segment
};

// the breakpoints of two schedules, merged, increasing, without repeats
SwitchInstants MergedBreakpoints(const PortSchedule& a, const PortSchedule& b);

// state of valve actuators at the end of the step (the value their act must reach)
// onoff: armature of valve i (0..3); 5/3: spool position (m)
double ValveStateAtEnd(const CylinderConfig& c, int valve, const ValveInputs& in);

// true if the cylinder's valves carry state in d->act (spool lag, on/off delays)
bool ValvesHaveState(const CylinderConfig& c);

}  // namespace pneumatic

#endif  // PNEUMATIC_VALVES_H_
