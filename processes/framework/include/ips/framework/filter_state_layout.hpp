#pragma once
// Order of ips::filter_state_t's covariance (documented in lcmtypes/ips_filter_state_t.lcm): the offset of each
// 3-vector of the filter's error state. Producers (the filter) and consumers (the tracker's prior) use these;
// the filter checks at compile time that they equal its own state layout.
namespace ips::fw::filter_state_layout {
inline constexpr int kPosition = 0;
inline constexpr int kVelocity = 3;
inline constexpr int kAcceleration = 6;
inline constexpr int kAccelBias = 9;
inline constexpr int kAngularRate = 12;
inline constexpr int kGyroBias = 15;
inline constexpr int kAttitude = 18;
inline constexpr int kDim = 21;
}  // namespace ips::fw::filter_state_layout
