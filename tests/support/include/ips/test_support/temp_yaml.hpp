#pragma once
// A YAML file for a test (a config under test, written from its text): the OpenCV FileStorage header, then `text`,
// into the test's temporary directory. Returns its path.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace ips::test_support {

inline std::string writeTempYaml(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << "%YAML:1.0\n---\n" << text;
  return path;
}

}  // namespace ips::test_support
