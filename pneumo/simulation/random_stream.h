// Seeded random numbers that are the same on every platform and standard library: logs made
// with the same seed are the same bit for bit.
#ifndef PNEUMATIC_RANDOM_STREAM_H_
#define PNEUMATIC_RANDOM_STREAM_H_

#include <cmath>
#include <cstdint>
#include <random>
#include <sstream>
#include <string>

namespace pneumatic {

// one random stream per (seed, cylinder, purpose): SplitMix64 of the three, feeding mt19937_64
// (whose output the standard fixes); uniform and Gaussian draws written out here, so the log
// does not depend on the standard library's distributions
class Stream {
 public:
  Stream(std::uint64_t seed, std::uint64_t cylinder, std::uint64_t purpose)
      : engine_(Mix(Mix(Mix(seed) ^ cylinder) ^ purpose)) {}
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // the stream's whole state as text, and back (false, unchanged, if the text is not one)
  std::string Save() const {
    std::ostringstream out;
    out << engine_;
    return out.str();
  }
  bool Load(const std::string& text) {
    std::istringstream in(text);
    std::mt19937_64 engine;
    if (!(in >> engine)) return false;
    engine_ = engine;
    return true;
  }
  double Gaussian() {  // Box-Muller, one draw per call
    double u1 = 1 - Uniform(), u2 = Uniform();
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * 3.14159265358979323846 * u2);
  }

 private:
  static std::uint64_t Mix(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  std::mt19937_64 engine_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_RANDOM_STREAM_H_
