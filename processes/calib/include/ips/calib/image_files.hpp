#pragma once
// The image files a calibration tool reads (--left, --right): a shell pattern, expanded by POSIX glob (sorted, with
// the shell's syntax including [..] sets, which cv::glob lacks).
#include <string>
#include <vector>

namespace ips::calib {

// The files matching `pattern`, sorted; empty when none does.
std::vector<std::string> matchingFiles(const std::string& pattern);

}  // namespace ips::calib
