#pragma once
// The command-line parser of the project's executables: "--name value", "--name=value" and "--flag" options,
// short or old spellings of them ("-u", "--lcmurl"), options given several times, an error naming the option for
// anything unknown or malformed, and a generated --help text. It depends on nothing but the standard library, so
// that the process engine (procman) shares it without the rest of the project.
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace ips {

class ArgError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Args {
 public:
  // `summary` is the first line of --help.
  Args(int argc, char** argv, std::string summary);

  // Declare options before calling parse(); each returns *this for chaining. A help text may hold several lines
  // ('\n'); --help indents the following ones under the first.
  Args& option(const std::string& name, const std::string& value_name, const std::string& help,
               const std::string& default_value = "");
  Args& required(const std::string& name, const std::string& value_name, const std::string& help);
  Args& flag(const std::string& name, const std::string& help);
  // An option that may be given several times; getAll() returns its values in the order given.
  Args& repeated(const std::string& name, const std::string& value_name, const std::string& help);
  // Another spelling of a declared option: a short form ("-u") or an old long name ("--lcmurl"), listed with it.
  Args& alias(const std::string& spelling, const std::string& name);
  // A heading in --help before the options declared next ("Actions").
  Args& section(const std::string& title);
  // The usage line of --help after "Usage: " (default: "PROGRAM [options] POSITIONAL...").
  Args& usage(const std::string& text);
  // Text at the end of --help (exit status, environment).
  Args& epilog(const std::string& text);
  // Accept positional arguments (they are returned by positional()).
  Args& positionals(const std::string& name, const std::string& help, size_t min_count, size_t max_count);

  // Parses argv. Returns false when --help was given (the help text is printed to stdout); throws ArgError
  // naming the option on any error.
  bool parse();

  std::string get(const std::string& name) const;
  bool has(const std::string& name) const;  // given on the command line (or has a non-empty default)
  bool isSet(const std::string& name) const { return has(name); }
  double getDouble(const std::string& name) const;
  long long getInt(const std::string& name) const;
  bool getFlag(const std::string& name) const;
  std::vector<std::string> getAll(const std::string& name) const;
  const std::vector<std::string>& positional() const { return positional_; }
  std::string help() const;
  const std::string& program() const { return program_; }

 private:
  struct Spec {
    std::string value_name;
    std::string help;
    std::string default_value;
    bool is_flag = false;
    bool is_required = false;
    bool is_repeated = false;
    std::vector<std::string> aliases;
  };
  // Resolves a spelling to the declared option's name ("" when unknown).
  std::string canonical(const std::string& spelling) const;
  std::vector<std::string> argv_;
  std::string program_;
  std::string summary_;
  std::vector<std::string> order_;  // option names, and section headings marked by a leading '\n'
  std::map<std::string, Spec> specs_;
  std::map<std::string, std::string> aliases_;              // spelling -> option name
  std::map<std::string, std::vector<std::string>> values_;  // every value given, in order
  std::string usage_, epilog_;
  std::vector<std::string> positional_;
  std::string positional_name_, positional_help_;
  size_t positional_min_ = 0, positional_max_ = 0;
};

// "1,2,4": comma-separated integers, each at least `min_value`; throws ArgError naming `what` on an empty list or a
// bad item.
std::vector<int> parseIntList(const std::string& text, const std::string& what, int min_value);

}  // namespace ips
