#pragma once
// Small valid messages of procman's types (orders, deputy info, output, discovery), each with one command and
// every variable-length field in use, for tests that encode or mutate them and for the fuzz targets' seeds.
#include <procman_lcm/cmd_t.hpp>
#include <procman_lcm/deputy_info_t.hpp>
#include <procman_lcm/discovery_t.hpp>
#include <procman_lcm/orders_t.hpp>
#include <procman_lcm/output_t.hpp>
#include <string>

namespace ips::test_support {

inline procman_lcm::cmd_t sampleProcmanCommand(const std::string& id = "tracker") {
  procman_lcm::cmd_t cmd{};
  cmd.command_id = id;
  cmd.exec_str = "build/bin/tracker --calib $IPS_CALIB";
  cmd.group = "ips";
  cmd.auto_respawn = true;
  cmd.stop_signal = 15;
  cmd.stop_time_allowed = 7;
  return cmd;
}

inline procman_lcm::orders_t sampleOrders(const std::string& deputy = "local", int64_t utime = 1000) {
  procman_lcm::orders_t orders{};
  orders.utime = utime;
  orders.deputy_id = deputy;
  orders.sheriff_id = "sheriff";
  orders.ncmds = 1;
  orders.cmds.resize(1);
  orders.cmds[0].cmd = sampleProcmanCommand();
  orders.cmds[0].desired_runid = 1;
  orders.cmds[0].force_quit = false;
  return orders;
}

inline procman_lcm::deputy_info_t sampleDeputyInfo(const std::string& deputy = "local", int64_t utime = 1000) {
  procman_lcm::deputy_info_t info{};
  info.utime = utime;
  info.deputy_id = deputy;
  info.ncmds = 1;
  info.cmds.resize(1);
  info.cmds[0].cmd = sampleProcmanCommand();
  info.cmds[0].pid = 42;
  info.cmds[0].actual_runid = 1;
  return info;
}

inline procman_lcm::output_t sampleOutput(const std::string& deputy = "local", int64_t utime = 1000) {
  procman_lcm::output_t output{};
  output.utime = utime;
  output.deputy_id = deputy;
  output.num_commands = 1;
  output.command_ids = {"tracker"};
  output.text = {"tracker: running\n"};
  return output;
}

inline procman_lcm::discovery_t sampleDiscovery(int64_t utime = 1000) {
  procman_lcm::discovery_t discovery{};
  discovery.utime = utime;
  discovery.transmitter_id = "sheriff";
  discovery.nonce = 7;
  return discovery;
}

}  // namespace ips::test_support
