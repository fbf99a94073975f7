#include "diagnosis/noise_floor.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace pneumatic::diagnosis {
namespace {

// standard normal draws from a 64-bit generator of our own (SplitMix64, Steele et al. 2014) and the
// Box-Muller transform: the same numbers on every platform and standard library
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : state_(seed) {}
  double Next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(Bits() >> 11) + 0.5) * 0x1.0p-53, u2 = static_cast<double>(Bits() >> 11) * 0x1.0p-53;
    const double radius = std::sqrt(-2 * std::log(u1));
    spare_ = radius * std::sin(2 * M_PI * u2), has_spare_ = true;
    return radius * std::cos(2 * M_PI * u2);
  }

 private:
  std::uint64_t Bits() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::uint64_t state_;
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace

double SensorNoise(const std::vector<double>& y) {
  if (y.size() < 8) return 0;
  std::vector<double> d;
  d.reserve(y.size() - 2);
  for (size_t i = 1; i + 1 < y.size(); ++i) d.push_back(std::fabs(y[i + 1] - 2 * y[i] + y[i - 1]));
  const auto quartile = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 4);
  std::nth_element(d.begin(), quartile, d.end());
  // noise_floor.h: the lower quartile of |d| for d ~ N(0, 6 sigma^2) is 0.3186 sqrt(6) sigma
  return *quartile / (0.318639 * std::sqrt(6.0));
}

std::vector<double> SensorNoise(const Measurements& meas) {
  std::vector<double> sigma;
  for (int s = 0; s < meas.signals(); ++s) sigma.push_back(SensorNoise(meas.Signal(s)));
  return sigma;
}

Measurements WithAddedNoise(const Measurements& meas, const std::vector<double>& sigma, unsigned long long seed) {
  Measurements out = meas;
  Gaussian normal(seed);
  // the velocity estimate's window, as PrepareMeasurements has it (measurements.cc)
  const int half = VelocityHalfWindow(meas.period);
  for (size_t c = 0; c < out.cylinders.size(); ++c) {
    CylinderSeries& cyl = out.cylinders[c];
    for (int k = 0; k < kSignalsPerCylinder; ++k) {
      const double sd = sigma[kSignalsPerCylinder * c + k];
      std::vector<double> noise(cyl.signal[k].size());
      for (double& n : noise) n = sd * normal.Next();
      for (size_t row = 0; row < noise.size(); ++row) cyl.signal[k][row] += noise[row];
      // the Savitzky-Golay estimate is linear in x: the noise moves it by its own estimate
      if (k == kPosition) {
        const std::vector<double> dv = EstimateVelocity(noise, meas.period, half);
        for (size_t row = 0; row < dv.size(); ++row) cyl.velocity[row] += dv[row];
      }
    }
  }
  return out;
}

std::vector<double> FirstRowNoise(const Measurements& meas, const Windows& windows, const Prediction& p) {
  std::vector<double> sigma;
  for (int s = 0; s < meas.signals(); ++s) {
    std::vector<double> e;
    for (int start : windows.starts) {
      const int row = start + 1;
      if (row < meas.rows() && std::isfinite(p.simulated[s][row])) e.push_back(std::fabs(p.simulated[s][row] - meas.Signal(s)[row]));
    }
    if (e.size() < 8) {
      sigma.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    const auto median = e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2);
    std::nth_element(e.begin(), median, e.end());
    // noise_floor.h: the median of |z| for z ~ N(0, 2 sigma^2) is 0.6745 sqrt(2) sigma
    sigma.push_back(*median / (0.674490 * std::sqrt(2.0)));
  }
  return sigma;
}

double GapOverFloor(const std::vector<double>& signal_gap, const NoiseFloor& floor) {
  const size_t n = floor.signal_floor.size();
  if (n == 0 || signal_gap.size() != n) return std::nan("");
  double sum = 0;
  for (size_t s = 0; s < n; ++s) {
    const double f2 = floor.signal_floor[s] * floor.signal_floor[s] + floor.discretisation_gap * floor.discretisation_gap;
    if (!(f2 > 0) || !std::isfinite(f2) || !std::isfinite(signal_gap[s])) return std::nan("");
    sum += signal_gap[s] * signal_gap[s] / f2;
  }
  return std::sqrt(sum / static_cast<double>(n));
}

NoiseFloor EstimateNoiseFloor(const mjModel* m, const SignalModel& sensors, const Measurements& meas, const GapOptions& g,
                              const Evaluated& base, double discretisation_gap) {
  NoiseFloor f;
  f.sensor_noise = SensorNoise(meas);
  const std::vector<double> first_row = FirstRowNoise(meas, g.windows, base.prediction);
  for (size_t s = 0; s < f.sensor_noise.size(); ++s) f.sensor_noise[s] = std::min(f.sensor_noise[s], first_row[s]);
  f.discretisation_gap = std::isfinite(discretisation_gap) ? discretisation_gap : 0;
  f.carried.assign(f.sensor_noise.size(), 0);
  const Evaluated noisy = Evaluate(m, sensors, WithAddedNoise(meas, f.sensor_noise, 0x5EEDull), g);
  if (!noisy.error.empty()) f.error = noisy.error;
  double sum = 0;
  for (int s = 0; s < meas.signals(); ++s) {
    if (noisy.error.empty()) {
      double sq = 0;
      int n = 0;
      for (int row = 0; row < meas.rows(); ++row) {
        const double a = noisy.prediction.simulated[s][row], b = base.prediction.simulated[s][row];
        if (std::isnan(a) || std::isnan(b)) continue;
        sq += (a - b) * (a - b), ++n;
      }
      f.carried[s] = n ? std::sqrt(sq / n) : 0;
    }
    const double floor_s = std::hypot(f.sensor_noise[s], f.carried[s]) / g.signal_scale[s];
    f.signal_floor.push_back(floor_s);
    sum += floor_s * floor_s;
  }
  f.floor = std::sqrt(sum / std::max(meas.signals(), 1) + f.discretisation_gap * f.discretisation_gap);
  return f;
}

}  // namespace pneumatic::diagnosis
