#include "piperun/edit/edit.h"

#include <charconv>
#include <cmath>

namespace piperun {

namespace {

// Shortest text that reads back to the same double.
std::string number(double value) {
  char buffer[32];
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, written.ptr);
}

std::string point(const Eigen::Vector3d& p) { return number(p.x()) + " " + number(p.y()) + " " + number(p.z()); }

std::optional<int> parseId(const std::string& word) {
  int value = 0;
  const auto parsed = std::from_chars(word.data(), word.data() + word.size(), value);
  if (parsed.ec != std::errc() || parsed.ptr != word.data() + word.size()) return std::nullopt;
  return value;
}

std::optional<double> parseNumber(const std::string& word) {
  double value = 0.0;
  const auto parsed = std::from_chars(word.data(), word.data() + word.size(), value);
  if (parsed.ec != std::errc() || parsed.ptr != word.data() + word.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

// Checks the word count and parses the numbers of one command form, failing with that form.
class Form {
 public:
  Form(const std::vector<std::string>& words, const char* usage) : words_(words), usage_(usage) {}

  void expectCount(std::size_t minimum, std::size_t maximum) const {
    if (words_.size() < minimum || words_.size() > maximum) fail();
  }
  int id(std::size_t index) const {
    const auto value = parseId(words_[index]);
    if (!value) fail();
    return *value;
  }
  double number(std::size_t index) const {
    const auto value = parseNumber(words_[index]);
    if (!value) fail();
    return *value;
  }
  Eigen::Vector3d point(std::size_t index) const { return {number(index), number(index + 1), number(index + 2)}; }
  [[noreturn]] void fail() const { throw EditError(std::string("expected \"") + usage_ + "\""); }

 private:
  const std::vector<std::string>& words_;
  const char* usage_;
};

std::optional<Edit> parseJointEdit(const std::vector<std::string>& words) {
  Edit edit;
  if (words.size() >= 2 && words[1] == "add") {
    const Form form(words, "joint add PIPE PIPE");
    form.expectCount(4, 4);
    edit.kind = EditKind::AddJoint;
    edit.id = form.id(2);
    edit.otherId = form.id(3);
    return edit;
  }
  const Form form(words, "joint ID accept|reject|propose");
  form.expectCount(3, 3);
  edit.id = form.id(1);
  if (words[2] == "accept") {
    edit.kind = EditKind::AcceptJoint;
  } else if (words[2] == "reject") {
    edit.kind = EditKind::RejectJoint;
  } else if (words[2] == "propose") {
    edit.kind = EditKind::ProposeJoint;
  } else {
    form.fail();
  }
  return edit;
}

std::optional<Edit> parsePipeEdit(const std::vector<std::string>& words) {
  Edit edit;
  if (words.size() >= 2 && words[1] == "fit-box") {
    const Form form(words, "pipe fit-box X0 Y0 Z0 X1 Y1 Z1");
    form.expectCount(8, 8);
    edit.kind = EditKind::FitInBox;
    edit.point = form.point(2);
    edit.point2 = form.point(5);
    return edit;
  }
  if (words.size() >= 2 && words[1] == "fit-point") {
    const Form form(words, "pipe fit-point X Y Z [REACH]");
    form.expectCount(5, 6);
    edit.kind = EditKind::FitAround;
    edit.point = form.point(2);
    edit.value = words.size() == 6 ? form.number(5) : kDefaultFitReach;
    if (!(edit.value > 0.0)) form.fail();
    return edit;
  }
  const Form general(words, "pipe ID accept|delete|restore|snap|radius R|merge ID|split X Y Z|move-end start|end X Y Z");
  if (words.size() < 3) general.fail();
  edit.id = general.id(1);
  const std::string& verb = words[2];
  if (verb == "accept" || verb == "delete" || verb == "restore" || verb == "snap") {
    const std::string usage = "pipe ID " + verb;
    Form(words, usage.c_str()).expectCount(3, 3);
    edit.kind = verb == "accept"   ? EditKind::AcceptPipe
                : verb == "delete" ? EditKind::DeletePipe
                : verb == "restore" ? EditKind::RestorePipe
                                    : EditKind::SnapRadius;
  } else if (verb == "radius") {
    const Form form(words, "pipe ID radius R (metres, positive)");
    form.expectCount(4, 4);
    edit.kind = EditKind::SetRadius;
    edit.value = form.number(3);
    if (!(edit.value > 0.0)) form.fail();
  } else if (verb == "merge") {
    const Form form(words, "pipe ID merge ID");
    form.expectCount(4, 4);
    edit.kind = EditKind::MergePipes;
    edit.otherId = form.id(3);
  } else if (verb == "split") {
    const Form form(words, "pipe ID split X Y Z");
    form.expectCount(6, 6);
    edit.kind = EditKind::SplitPipe;
    edit.point = form.point(3);
  } else if (verb == "move-end") {
    const Form form(words, "pipe ID move-end start|end X Y Z");
    form.expectCount(7, 7);
    if (words[3] != "start" && words[3] != "end") form.fail();
    edit.kind = EditKind::MoveEnd;
    edit.side = words[3] == "start" ? 0 : 1;
    edit.point = form.point(4);
  } else {
    general.fail();
  }
  return edit;
}

}  // namespace

std::string toCommand(const Edit& edit) {
  const std::string pipe = "pipe " + std::to_string(edit.id);
  switch (edit.kind) {
    case EditKind::AcceptJoint: return "joint " + std::to_string(edit.id) + " accept";
    case EditKind::RejectJoint: return "joint " + std::to_string(edit.id) + " reject";
    case EditKind::ProposeJoint: return "joint " + std::to_string(edit.id) + " propose";
    case EditKind::AddJoint: return "joint add " + std::to_string(edit.id) + " " + std::to_string(edit.otherId);
    case EditKind::DeletePipe: return pipe + " delete";
    case EditKind::RestorePipe: return pipe + " restore";
    case EditKind::AcceptPipe: return pipe + " accept";
    case EditKind::MergePipes: return pipe + " merge " + std::to_string(edit.otherId);
    case EditKind::SplitPipe: return pipe + " split " + point(edit.point);
    case EditKind::SetRadius: return pipe + " radius " + number(edit.value);
    case EditKind::SnapRadius: return pipe + " snap";
    case EditKind::MoveEnd: return pipe + " move-end " + (edit.side == 0 ? "start " : "end ") + point(edit.point);
    case EditKind::FitInBox: return "pipe fit-box " + point(edit.point) + " " + point(edit.point2);
    case EditKind::FitAround: return "pipe fit-point " + point(edit.point) + " " + number(edit.value);
  }
  return {};
}

std::optional<Edit> parseEdit(const std::vector<std::string>& words) {
  if (words.empty()) return std::nullopt;
  if (words[0] == "joint") return parseJointEdit(words);
  if (words[0] == "pipe") return parsePipeEdit(words);
  return std::nullopt;
}

}  // namespace piperun
