#pragma once
// A small, portable random generator (splitmix64) so that a seed gives the same numbers on every platform and
// standard library; streams are derived from (seed, purpose, index) so that sensors and image rows draw
// independently and in any order (parallel rendering stays deterministic).
#include <cmath>
#include <cstdint>

namespace ips::sim {

inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

inline uint64_t streamSeed(uint64_t seed, uint64_t purpose, uint64_t index = 0) {
  return mix64(mix64(seed + 0x9e3779b97f4a7c15ULL * (purpose + 1)) ^ (index * 0xd1b54a32d192ed03ULL + purpose));
}

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return mix64(state_);
  }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
  double normal() {                                                                            // Box-Muller
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform(), u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2 * M_PI * u2);
  }

 private:
  uint64_t state_;
  double spare_ = 0;
  bool has_spare_ = false;
};

// The sum of four 16-bit uniforms minus its mean (Irwin-Hall): a pixel's noise before scaling, from its row's stream
// (a stream's state, advanced as Rng::next does). Variance 4 * (65536^2 - 1) / 12.
inline float irwinHall4(uint64_t& state) {
  state += 0x9e3779b97f4a7c15ULL;
  const uint64_t r = mix64(state);
  return static_cast<float>((r & 0xffff) + ((r >> 16) & 0xffff) + ((r >> 32) & 0xffff) + (r >> 48)) - 2.0f * 65535.0f;
}

// Purposes of the random streams of one scenario.
enum RngStream : uint64_t {
  kStreamHead = 1,
  kStreamImu,
  kStreamTilt,
  kStreamCamera,
  kStreamPixels,
  kStreamWorld,
  kStreamCalibration  // last, so that adding it left the other streams as they were
};

}  // namespace ips::sim
