// libFuzzer target: one message type's decode and validate, as every receiving process (and procman's deputy
// and sheriff, for the PM_* types) runs them on whatever arrives on the bus. Built once per type with IPS_FUZZ_TYPE set
// to the type (tests/fuzz/CMakeLists.txt). Finds: exceptions out of the decoder, allocations from declared lengths,
// memory errors (ASan), undefined behaviour (UBSan).
#include <cstddef>
#include <cstdint>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/keyframe_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <type_traits>
#if __has_include(<procman_lcm/orders_t.hpp>)
#include <procman_lcm/deputy_info_t.hpp>
#include <procman_lcm/discovery_t.hpp>
#include <procman_lcm/orders_t.hpp>
#include <procman_lcm/output_t.hpp>
#endif

#include "ips/framework/validate.hpp"

namespace {
template <class T, class = void>
struct HasValidate : std::false_type {};
template <class T>
struct HasValidate<T, std::void_t<decltype(ips::fw::validate(std::declval<const T&>()))>> : std::true_type {};

template <class Msg>
void validateIfDefined(const Msg& msg) {
  validateIfDefined(msg);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using Msg = IPS_FUZZ_TYPE;
  Msg msg;
  // No try: an exception escaping the decoder is a finding (libFuzzer reports it as a crash).
  if (msg.decode(data, 0, static_cast<int>(size)) < 0) return 0;
  validateIfDefined(msg);
  // What decoded must encode again to the same length (the decoder consumed what it declared).
  if (msg.getEncodedSize() > static_cast<int>(size)) __builtin_trap();
  return 0;
}
