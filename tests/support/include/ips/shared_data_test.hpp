#pragma once
// Tests on the shared evaluation data (ips::dataDir(): ../shared/data or $IPS_DATA_DIR) skip, saying what is
// missing, where the data is not there, instead of failing on an unreadable file.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "ips/data_dir.hpp"

// In a test body: skips the test unless dataPath(relative) exists.
#define IPS_REQUIRE_SHARED_DATA(relative)                                                                     \
  do {                                                                                                        \
    const std::string ips_required_path_ = ips::dataPath(relative);                                           \
    if (!std::filesystem::exists(ips_required_path_))                                                         \
      GTEST_SKIP() << ips_required_path_ << " is missing: the shared evaluation data (../shared/data beside " \
                   << "the project, or $IPS_DATA_DIR) is not here";                                           \
  } while (0)
