#include "piperun/ui/commands.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace piperun::ui {
namespace {

CommandRegistry registryRecording(std::vector<std::vector<std::string>>& calls) {
  CommandRegistry registry;
  registry.add("select", "pipe|joint ID", "select an element", [&calls](const std::vector<std::string>& args) {
    calls.push_back(args);
    return "selected " + args.at(1);
  });
  registry.add("fail", "", "always fails",
               [](const std::vector<std::string>&) -> std::string { throw CommandError("it failed"); });
  return registry;
}

TEST(CommandRegistry, RunsANamedCommandWithItsArguments) {
  std::vector<std::vector<std::string>> calls;
  const CommandRegistry registry = registryRecording(calls);
  EXPECT_EQ(registry.run("  select   pipe 3 "), "selected 3");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0], (std::vector<std::string>{"pipe", "3"}));
}

TEST(CommandRegistry, IgnoresBlankLinesAndComments) {
  std::vector<std::vector<std::string>> calls;
  const CommandRegistry registry = registryRecording(calls);
  EXPECT_EQ(registry.run(""), "");
  EXPECT_EQ(registry.run("# select pipe 1"), "");
  EXPECT_TRUE(calls.empty());
}

TEST(CommandRegistry, UnknownCommandNamesItself) {
  std::vector<std::vector<std::string>> calls;
  const CommandRegistry registry = registryRecording(calls);
  try {
    registry.run("explode now");
    FAIL() << "expected a CommandError";
  } catch (const CommandError& error) {
    EXPECT_NE(std::string(error.what()).find("'explode'"), std::string::npos) << error.what();
  }
}

TEST(CommandRegistry, ScriptErrorNamesFileAndLine) {
  std::vector<std::vector<std::string>> calls;
  const CommandRegistry registry = registryRecording(calls);
  const auto path = std::filesystem::temp_directory_path() / "piperun_ui_script_test.txt";
  std::ofstream(path) << "# a comment\nselect pipe 2\nfail\nselect pipe 9\n";
  try {
    registry.runScript(path);
    FAIL() << "expected a CommandError";
  } catch (const CommandError& error) {
    EXPECT_EQ(std::string(error.what()), path.string() + ":3: it failed");
  }
  ASSERT_EQ(calls.size(), 1u);  // Stopped at the failing line.
  std::filesystem::remove(path);
}

TEST(CommandRegistry, HelpListsCommandsInNameOrder) {
  std::vector<std::vector<std::string>> calls;
  const CommandRegistry registry = registryRecording(calls);
  const auto lines = registry.helpLines();
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "fail - always fails");
  EXPECT_EQ(lines[1], "select pipe|joint ID - select an element");
}

}  // namespace
}  // namespace piperun::ui
