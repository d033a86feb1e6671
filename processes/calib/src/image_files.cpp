#include "ips/calib/image_files.hpp"

#include <glob.h>

namespace ips::calib {

std::vector<std::string> matchingFiles(const std::string& pattern) {
  glob_t found{};
  std::vector<std::string> files;
  if (::glob(pattern.c_str(), 0, nullptr, &found) == 0)
    for (size_t i = 0; i < found.gl_pathc; ++i) files.emplace_back(found.gl_pathv[i]);
  globfree(&found);
  return files;
}

}  // namespace ips::calib
