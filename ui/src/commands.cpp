#include "piperun/ui/commands.h"

#include <fstream>
#include <sstream>

namespace piperun::ui {

std::vector<std::string> splitWords(const std::string& line) {
  std::istringstream stream(line);
  std::vector<std::string> words;
  for (std::string word; stream >> word;) words.push_back(word);
  return words;
}

void CommandRegistry::add(const std::string& name, const std::string& arguments, const std::string& description,
                          Handler handler) {
  commands_[name] = Command{name, arguments, description, std::move(handler)};
}

std::string CommandRegistry::run(const std::string& line) const {
  std::vector<std::string> words = splitWords(line);
  if (words.empty() || words.front().front() == '#') return {};
  const auto found = commands_.find(words.front());
  if (found == commands_.end()) throw CommandError("unknown command '" + words.front() + "' (help lists them)");
  words.erase(words.begin());
  return found->second.handler(words);
}

std::string CommandRegistry::runScript(const std::filesystem::path& path) const {
  std::ifstream file(path);
  if (!file) throw CommandError(path.string() + ": cannot open the script");
  int lineNumber = 0;
  std::string lastMessage;
  for (std::string line; std::getline(file, line);) {
    ++lineNumber;
    try {
      const std::string message = run(line);
      if (!message.empty()) lastMessage = message;
    } catch (const std::exception& error) {
      throw CommandError(path.string() + ":" + std::to_string(lineNumber) + ": " + error.what());
    }
  }
  return lastMessage;
}

std::vector<const CommandRegistry::Command*> CommandRegistry::list() const {
  std::vector<const Command*> result;
  for (const auto& entry : commands_) result.push_back(&entry.second);
  return result;
}

std::vector<std::string> CommandRegistry::helpLines() const {
  std::vector<std::string> lines;
  for (const Command* command : list()) {
    std::string usage = command->name;
    if (!command->arguments.empty()) usage += " " + command->arguments;
    lines.push_back(usage + " - " + command->description);
  }
  return lines;
}

}  // namespace piperun::ui
