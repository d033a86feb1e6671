// The filter's parameters from YAML: the filter type by name (config key `type` and the process's --filter), and
// config/filter.yaml against the built-in defaults.
#include <gtest/gtest.h>

#include "ips/filter/params.hpp"
#include "ips/test_support/temp_yaml.hpp"

using ips::test_support::writeTempYaml;

namespace {

using ips::filter::FilterType;

TEST(FilterParams, TheFilterTypeByName) {
  EXPECT_EQ(ips::filter::filterTypeFromString("ekf"), FilterType::Ekf);
  EXPECT_EQ(ips::filter::filterTypeFromString("ukf"), FilterType::Ukf);
  for (const char* bad : {"", "EKF", "ukf ", "kalman"}) EXPECT_FALSE(ips::filter::filterTypeFromString(bad)) << bad;
  for (FilterType t : {FilterType::Ekf, FilterType::Ukf})
    EXPECT_EQ(ips::filter::filterTypeFromString(ips::filter::toString(t)), t);
}

TEST(FilterParams, TypeFromTheConfigAndAnUnknownOneRefused) {
  EXPECT_EQ(ips::filter::loadFilterParams(ips::Config(writeTempYaml("ukf.yaml", "type: ukf\n"))).type, FilterType::Ukf);
  EXPECT_EQ(ips::filter::loadFilterParams(ips::Config(writeTempYaml("none.yaml", "gravity: 9.8\n"))).type,
            FilterType::Ekf);
  try {
    ips::filter::loadFilterParams(ips::Config(writeTempYaml("bad_type.yaml", "type: pf\n")));
    FAIL() << "type pf taken";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'type' must be 'ekf' or 'ukf', not 'pf'"), std::string::npos) << e.what();
  }
}

}  // namespace
