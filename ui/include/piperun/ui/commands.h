#pragma once
// Named commands: every studio action is a line of text ("view sphere", "select pipe 3",
// "rerun placement placement.center_bandwidth=0.02") run from a key, a widget or a script.

#include <filesystem>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace piperun::ui {

/// A command that cannot run: unknown name, wrong arguments, nothing to act on. what() is one line.
class CommandError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class CommandRegistry {
 public:
  /// Receives the words after the command name; returns a one-line message for the status bar
  /// (empty for none); throws CommandError.
  using Handler = std::function<std::string(const std::vector<std::string>& args)>;

  struct Command {
    std::string name;
    std::string arguments;    ///< Usage of the arguments, e.g. "pipe|joint|direction ID | none".
    std::string description;  ///< One line.
    Handler handler;
  };

  void add(const std::string& name, const std::string& arguments, const std::string& description, Handler handler);

  /// Runs one line: words separated by blanks; an empty line or one starting with '#' does nothing.
  std::string run(const std::string& line) const;

  /// Runs a script, one command a line; returns the last non-empty message. Stops at the first
  /// failing line with a CommandError "<file>:<line>: <message>".
  std::string runScript(const std::filesystem::path& path) const;

  /// The commands in name order.
  std::vector<const Command*> list() const;

  /// "name arguments — description" lines, for `help` and docs/STUDIO.md.
  std::vector<std::string> helpLines() const;

 private:
  std::map<std::string, Command> commands_;
};

/// Splits a line into blank-separated words.
std::vector<std::string> splitWords(const std::string& line);

}  // namespace piperun::ui
