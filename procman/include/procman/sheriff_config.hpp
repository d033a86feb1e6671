#pragma once
// The procman sheriff configuration format (the upstream procman format):
//
//   group "sensors" {                 # groups nest: group "a" { group "b" { ... } } is group "a/b"
//     cmd "camera" {
//       exec = "camera --config config/head.yaml";
//       deputy = "sensors";           # "host" is accepted as the older name; default: the sheriff's default
//       auto_respawn = "true";        # "true"/"false" (quoted or not) or 1/0
//       stop_signal = 15;             # default 2 (SIGINT)
//       stop_time_allowed = 5;        # seconds before SIGKILL, default 7
//     }
//   }
//   cmd "tool" { exec = "..."; }      # a command in no group
//   script "start_all" {
//     start group "sensors" wait "running";   # start|stop|restart  everything|group "G"|cmd "C"  [wait
//     "running"|"stopped"] wait ms 500; wait cmd "camera" status "running";     # wait cmd|group "X" status
//     "running"|"stopped" run_script "other";
//   }
//
// Comments run from '#' to the end of the line. Errors name the file, line and column.
#include <stdexcept>
#include <string>
#include <vector>

namespace ips::procman {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CommandConfig {
  std::string id;
  std::string exec;
  std::string deputy;  // "" = the sheriff's default deputy
  std::string group;   // full path "a/b", "" for none
  bool auto_respawn = false;
  int stop_signal = 2;
  double stop_time_allowed = 7.0;
  int line = 0;
};

enum class ActionType { kStart, kStop, kRestart, kWaitMs, kWaitStatus, kRunScript };

struct ScriptAction {
  ActionType type = ActionType::kStart;
  std::string target_kind;  // "everything", "group" or "cmd" (start/stop/restart/wait status)
  std::string target;       // group path or command id; script name for run_script
  std::string wait_status;  // "", "running" or "stopped"
  int delay_ms = 0;         // wait ms
  std::string describe() const;
};

struct Script {
  std::string name;
  std::vector<ScriptAction> actions;
};

struct SheriffConfig {
  std::vector<CommandConfig> commands;
  std::vector<Script> scripts;
  std::vector<std::string> groups;  // every group path, parents before children

  const Script* findScript(const std::string& name) const;
  bool hasGroup(const std::string& path) const;
};

// Parses config text; `source` names it in error messages. Checks that command ids are unique per deputy,
// that every command has an exec string, and that scripts only name known commands, groups and scripts.
SheriffConfig parseSheriffConfig(const std::string& text, const std::string& source = "<config>");
SheriffConfig loadSheriffConfig(const std::string& path);

// True if `group` is `path` or inside it ("a/b" is inside "a").
bool groupContains(const std::string& path, const std::string& group);

}  // namespace ips::procman
