#pragma once
// The common clock of the sensor head. Every process on a machine stamps with this one function, so stamps
// from different processes compare directly. It is CLOCK_REALTIME (microseconds since the Unix epoch): the
// clock that chrony and PTP (phc2sys) discipline, so stamps of several machines agree to the accuracy of that
// synchronisation (see processes/drivers/README.md, "Time base"). Aravis stamps buffer arrival with the same
// clock (g_get_real_time), so camera arrival times need no conversion.
//
// Only drivers read this clock, at the moment data arrives; algorithms take time from the data.
#include <cstdint>

namespace ips::drivers {

// Now on the common clock [us].
int64_t commonClockNowUs();

}  // namespace ips::drivers
