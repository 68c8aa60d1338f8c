// Text point readers: XYZ/TXT/CSV/ASC (one point per line) and Leica PTS (point-count lines, each
// followed by that many point lines).
//
// XYZ/TXT/CSV/ASC
//   Fields are separated by spaces, tabs, commas or semicolons. Blank lines and lines starting with
//   '#' or '//' are skipped.
//
//   Header: when the first line that is not skipped has a non-number among its first three fields,
//   it names the columns (case-insensitive, surrounding quotes ignored):
//     x y z                                       position (required)
//     nx ny nz, normal_x normal_y normal_z        normal
//     r g b, red green blue                       colour, 0..255
//     i, intensity                                intensity
//     label, class, classification                label, an integer
//   Other names are ignored. A comment line before the first point whose fields name x, y and z is
//   the header too (CloudCompare writes "//X,Y,Z,R,G,B").
//
//   Without a header the layout is decided once, from the number of fields n of the first point
//   line, and then fixed for the whole file; fields beyond the layout are ignored. "Colour" means
//   the three fields are integers 0..255 on that first line:
//     n >= 9 and fields 4-6 colour     x y z r g b nx ny nz   (CloudCompare's order)
//     n >= 7 and fields 5-7 colour     x y z i r g b          (Leica's order)
//     n >= 6 and fields 4-6 colour     x y z r g b
//     n >= 6                           x y z nx ny nz
//     n = 4 or 5                       x y z i
//     n = 3                            x y z
//
//   A point line with fewer fields than its layout needs, or a non-number where the layout needs a
//   number, is an error naming the line. Colour values must lie in 0..255 (rounded to integers);
//   labels must be integers.
//
// PTS (Leica)
//   A line holding a single integer is a point count; exactly that many point lines
//   x y z [intensity [r g b]] follow, and several such blocks may follow each other. The layout
//   comes from the first point line: 3 fields x y z, 4 or 5 x y z i, 6 x y z r g b, 7 or more
//   x y z i r g b. Intensity is delivered as stored (often -2048..2047). Blank lines are skipped.
//   The total point count is known only at the end, so CloudInfo::declaredPoints stays empty.

#include "io/readers.h"
#include "io/text_lines.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace piperun::io {

namespace {

enum Slot { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kIntensitySlot, kLabelSlot, kSlotCount };
constexpr std::array<const char*, kSlotCount> kSlotNames = {"x", "y", "z", "nx", "ny", "nz", "r",
                                                            "g", "b", "intensity", "label"};
constexpr int kAbsent = -1;

/// Which 0-based column holds each value (kAbsent when the file has none), and the field names
/// for CloudInfo and error messages.
struct ColumnLayout {
  std::array<int, kSlotCount> column;
  std::vector<std::string> fieldNames;

  ColumnLayout() { column.fill(kAbsent); }

  /// A layout whose slots occupy consecutive columns from 0 in the given order.
  ColumnLayout(std::initializer_list<Slot> slots) {
    column.fill(kAbsent);
    int next = 0;
    for (const Slot slot : slots) {
      column[slot] = next++;
      fieldNames.emplace_back(kSlotNames[slot]);
    }
  }

  bool has(Slot slot) const { return column[slot] != kAbsent; }

  unsigned attributes() const {
    unsigned bits = kNoAttributes;
    if (has(kNx)) bits |= kNormals;
    if (has(kRed)) bits |= kColors;
    if (has(kIntensitySlot)) bits |= kIntensity;
    if (has(kLabelSlot)) bits |= kLabels;
    return bits;
  }

  std::size_t requiredFields() const {
    return static_cast<std::size_t>(*std::max_element(column.begin(), column.end()) + 1);
  }
};

bool isBlank(std::string_view line) {
  return line.find_first_not_of(" \t\r,;") == std::string_view::npos;
}

/// The text after a leading '#' or '//' (leading whitespace allowed), or nothing when the line is
/// not a comment.
std::optional<std::string_view> commentText(std::string_view line) {
  const auto start = line.find_first_not_of(" \t");
  if (start == std::string_view::npos) return std::nullopt;
  line.remove_prefix(start);
  if (line.substr(0, 1) == "#") return line.substr(1);
  if (line.substr(0, 2) == "//") return line.substr(2);
  return std::nullopt;
}

/// A field shortened for an error message.
std::string quoted(std::string_view field) {
  constexpr std::size_t kMaxShown = 24;
  if (field.size() <= kMaxShown) return "'" + std::string(field) + "'";
  return "'" + std::string(field.substr(0, kMaxShown)) + "...'";
}

std::string lowerUnquoted(std::string_view name) {
  while (!name.empty() && (name.front() == '"' || name.front() == '\'')) name.remove_prefix(1);
  while (!name.empty() && (name.back() == '"' || name.back() == '\'')) name.remove_suffix(1);
  std::string lower(name);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower;
}

std::optional<Slot> slotForHeaderName(const std::string& name) {
  static constexpr std::pair<std::string_view, Slot> kHeaderNames[] = {
      {"x", kX},          {"y", kY},          {"z", kZ},
      {"nx", kNx},        {"ny", kNy},        {"nz", kNz},
      {"normal_x", kNx},  {"normal_y", kNy},  {"normal_z", kNz},
      {"r", kRed},        {"g", kGreen},      {"b", kBlue},
      {"red", kRed},      {"green", kGreen},  {"blue", kBlue},
      {"i", kIntensitySlot},      {"intensity", kIntensitySlot},
      {"label", kLabelSlot},      {"class", kLabelSlot},      {"classification", kLabelSlot},
  };
  for (const auto& [known, slot] : kHeaderNames) {
    if (name == known) return slot;
  }
  return std::nullopt;
}

/// All fields of a line (splitFields stores at most fields.size() of them).
std::vector<std::string_view> allFields(std::string_view line) {
  std::vector<std::string_view> fields;
  fields.resize(splitFields(line, fields));
  splitFields(line, fields);
  return fields;
}

/// True when the header fields name x, y and z (the test for a comment line being the header).
bool namesPosition(const std::vector<std::string_view>& fields) {
  bool x = false, y = false, z = false;
  for (const auto field : fields) {
    const auto slot = slotForHeaderName(lowerUnquoted(field));
    x |= slot == kX;
    y |= slot == kY;
    z |= slot == kZ;
  }
  return x && y && z;
}

ColumnLayout layoutFromHeader(const std::vector<std::string_view>& fields, const TextLines& lines) {
  ColumnLayout layout;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    layout.fieldNames.emplace_back(fields[i]);
    const auto slot = slotForHeaderName(lowerUnquoted(fields[i]));
    if (!slot) continue;
    if (layout.has(*slot)) {
      lines.fail("header names " + std::string(kSlotNames[*slot]) + " twice (columns " +
                 std::to_string(layout.column[*slot] + 1) + " and " + std::to_string(i + 1) + ")");
    }
    layout.column[*slot] = static_cast<int>(i);
  }
  for (const Slot slot : {kX, kY, kZ}) {
    if (!layout.has(slot)) {
      lines.fail("header names no " + std::string(kSlotNames[slot]) + " column, expected columns x, y and z");
    }
  }
  for (const Slot first : {kNx, kRed}) {
    const int named = layout.has(first) + layout.has(Slot(first + 1)) + layout.has(Slot(first + 2));
    if (named != 0 && named != 3) {
      lines.fail("header names only " + std::to_string(named) + " of " + kSlotNames[first] + " " +
                 kSlotNames[first + 1] + " " + kSlotNames[first + 2] + ", expected all three or none");
    }
  }
  return layout;
}

bool isNumber(std::string_view field) {
  double value;
  return parseNumber(field, value);
}

bool isColorTriple(const std::vector<std::string_view>& fields, std::size_t first) {
  for (std::size_t i = first; i < first + 3; ++i) {
    std::int64_t value;
    if (!parseNumber(fields[i], value) || value < 0 || value > 255) return false;
  }
  return true;
}

/// The layout of a file without a header, from its first point line (see the table at the top).
ColumnLayout layoutFromFirstPoint(const std::vector<std::string_view>& fields) {
  const std::size_t n = fields.size();
  if (n >= 9 && isColorTriple(fields, 3)) return {kX, kY, kZ, kRed, kGreen, kBlue, kNx, kNy, kNz};
  if (n >= 7 && isColorTriple(fields, 4)) return {kX, kY, kZ, kIntensitySlot, kRed, kGreen, kBlue};
  if (n >= 6 && isColorTriple(fields, 3)) return {kX, kY, kZ, kRed, kGreen, kBlue};
  if (n >= 6) return {kX, kY, kZ, kNx, kNy, kNz};
  if (n >= 4) return {kX, kY, kZ, kIntensitySlot};
  return {kX, kY, kZ};
}

/// Parses point lines by a fixed layout into a PointChunk.
class PointLineParser {
 public:
  explicit PointLineParser(ColumnLayout layout) : layout_(std::move(layout)), fields_(layout_.requiredFields()) {
    const std::size_t required = layout_.requiredFields();
    expectation_ = "expected at least " + std::to_string(required) + " fields (";
    for (std::size_t i = 0; i < required; ++i) expectation_ += (i ? " " : "") + layout_.fieldNames[i];
    expectation_ += ")";
  }

  const ColumnLayout& layout() const { return layout_; }

  void append(std::string_view line, const TextLines& lines, PointChunk& chunk) {
    const std::size_t count = splitFields(line, fields_);
    if (count < fields_.size()) {
      lines.fail(std::to_string(count) + (count == 1 ? " field, " : " fields, ") + expectation_);
    }
    chunk.positions.emplace_back(number<double>(kX, lines), number<double>(kY, lines), number<double>(kZ, lines));
    if (layout_.has(kNx)) {
      chunk.normals.emplace_back(number<float>(kNx, lines), number<float>(kNy, lines), number<float>(kNz, lines));
    }
    if (layout_.has(kRed)) chunk.colors.emplace_back(color(kRed, lines), color(kGreen, lines), color(kBlue, lines));
    if (layout_.has(kIntensitySlot)) chunk.intensities.push_back(number<float>(kIntensitySlot, lines));
    if (layout_.has(kLabelSlot)) chunk.labels.push_back(label(lines));
  }

 private:
  template <class T>
  T number(Slot slot, const TextLines& lines) const {
    const std::size_t column = columnOf(slot);
    T value;
    if (!parseNumber(fields_[column], value)) {
      lines.fail(quoted(fields_[column]) + " in column " + std::to_string(column + 1) + " (" + kSlotNames[slot] +
                 ") is not a number, " + expectation_);
    }
    return value;
  }

  std::uint8_t color(Slot slot, const TextLines& lines) const {
    const double value = number<double>(slot, lines);
    if (!(value >= 0.0 && value <= 255.0)) {
      lines.fail("colour " + std::string(kSlotNames[slot]) + " = " + quoted(fields_[columnOf(slot)]) +
                 " in column " + std::to_string(columnOf(slot) + 1) + ", expected 0..255");
    }
    return static_cast<std::uint8_t>(std::lround(value));
  }

  std::int32_t label(const TextLines& lines) const {
    const double value = number<double>(kLabelSlot, lines);
    if (!(value == std::floor(value) && value >= std::numeric_limits<std::int32_t>::min() &&
          value <= std::numeric_limits<std::int32_t>::max())) {
      lines.fail("label " + quoted(fields_[columnOf(kLabelSlot)]) + " in column " +
                 std::to_string(columnOf(kLabelSlot) + 1) + ", expected a 32-bit integer");
    }
    return static_cast<std::int32_t>(value);
  }

  std::size_t columnOf(Slot slot) const { return static_cast<std::size_t>(layout_.column[slot]); }

  ColumnLayout layout_;
  std::vector<std::string_view> fields_;
  std::string expectation_;
};

double fractionConsumed(const TextLines& lines) {
  if (lines.fileSize() == 0) return 1.0;
  return std::min(1.0, static_cast<double>(lines.bytesConsumed()) / static_cast<double>(lines.fileSize()));
}

CloudInfo textInfo(const char* format, const ColumnLayout& layout) {
  CloudInfo info;
  info.format = format;
  info.fields = layout.fieldNames;
  info.attributes = layout.attributes();
  return info;
}

/// Fills `chunk` with up to maxPoints points: first the point line kept back while the layout was
/// detected (when `firstPending`), then the lines `nextPointLine` yields.
template <class NextPointLine>
std::size_t readPointLines(PointChunk& chunk, std::size_t maxPoints, const std::string& firstPoint, bool& firstPending,
                           const TextLines& lines, PointLineParser& parser, NextPointLine&& nextPointLine) {
  chunk.clear();
  while (chunk.size() < maxPoints) {
    std::string_view line;
    if (firstPending) {
      line = firstPoint;
      firstPending = false;
    } else if (!nextPointLine(line)) {
      break;
    }
    parser.append(line, lines, chunk);
  }
  return chunk.size();
}

class XyzReader final : public PointReader {
 public:
  explicit XyzReader(const std::filesystem::path& path) : lines_(path), parser_(detectLayout()) {
    info_ = textInfo("XYZ text", parser_.layout());
  }

  const CloudInfo& info() const override { return info_; }
  double progress() const override { return fractionConsumed(lines_); }

  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    return readPointLines(chunk, maxPoints, firstPoint_, firstPointPending_, lines_, parser_,
                          [this](std::string_view& line) { return nextPointLine(line); });
  }

 private:
  bool nextPointLine(std::string_view& line) {
    while (lines_.next(line)) {
      if (!isBlank(line) && !commentText(line)) return true;
    }
    return false;
  }

  /// Reads up to the first point line: the header decides the layout, or else the first point
  /// does, which is then kept for the first read().
  ColumnLayout detectLayout() {
    std::string_view line;
    while (lines_.next(line)) {
      if (lines_.lineNumber() == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // UTF-8 BOM
      if (isBlank(line)) continue;
      if (const auto comment = commentText(line)) {
        const auto fields = allFields(*comment);
        if (namesPosition(fields)) return layoutFromHeader(fields, lines_);
        continue;
      }
      const auto fields = allFields(line);
      const std::size_t leading = std::min<std::size_t>(3, fields.size());
      if (!std::all_of(fields.begin(), fields.begin() + leading, isNumber)) return layoutFromHeader(fields, lines_);
      firstPoint_ = line;
      firstPointPending_ = true;
      return layoutFromFirstPoint(fields);
    }
    return ColumnLayout{kX, kY, kZ};
  }

  TextLines lines_;
  std::string firstPoint_;
  bool firstPointPending_ = false;
  PointLineParser parser_;
  CloudInfo info_;
};

ColumnLayout ptsLayout(std::size_t fieldCount) {
  if (fieldCount >= 7) return {kX, kY, kZ, kIntensitySlot, kRed, kGreen, kBlue};
  if (fieldCount == 6) return {kX, kY, kZ, kRed, kGreen, kBlue};
  if (fieldCount >= 4) return {kX, kY, kZ, kIntensitySlot};
  return {kX, kY, kZ};
}

class PtsReader final : public PointReader {
 public:
  explicit PtsReader(const std::filesystem::path& path) : lines_(path), parser_(detectLayout()) {
    info_ = textInfo("PTS", parser_.layout());
  }

  const CloudInfo& info() const override { return info_; }
  double progress() const override { return fractionConsumed(lines_); }

  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    return readPointLines(chunk, maxPoints, firstPoint_, firstPointPending_, lines_, parser_,
                          [this](std::string_view& line) { return nextPointLine(line); });
  }

 private:
  // The shortest point line, "0 0 0\n", bounds how many points the rest of the file can hold.
  static constexpr std::uint64_t kMinPointLineBytes = 6;

  /// The next point line; count lines open blocks and are checked against the points that follow.
  bool nextPointLine(std::string_view& line) {
    while (lines_.next(line)) {
      const std::size_t count = splitFields(line, leadingFields_);
      if (count == 0) continue;
      std::int64_t declared;
      if (count == 1 && parseNumber(leadingFields_[0], declared)) {
        startBlock(declared);
        continue;
      }
      if (blockLine_ == 0) {
        lines_.fail("expected a point count (one integer) before the first point, found " + quoted(line));
      }
      if (pointsLeftInBlock_ == 0) {
        lines_.fail("more points than the count " + std::to_string(blockDeclared_) + " on line " +
                    std::to_string(blockLine_) + " declares");
      }
      --pointsLeftInBlock_;
      return true;
    }
    if (pointsLeftInBlock_ > 0) lines_.fail("the file ends early: " + blockShortfall());
    return false;
  }

  void startBlock(std::int64_t declared) {
    if (pointsLeftInBlock_ > 0) lines_.fail("a new point count comes early: " + blockShortfall());
    if (declared < 0) lines_.fail("point count " + std::to_string(declared) + " is negative");
    const std::uint64_t bytesLeft = lines_.fileSize() - std::min(lines_.fileSize(), lines_.bytesConsumed());
    // The last line may lack its newline.
    const std::uint64_t mostPoints = (bytesLeft + 1) / kMinPointLineBytes;
    if (static_cast<std::uint64_t>(declared) > mostPoints) {
      lines_.fail("point count " + std::to_string(declared) + " is more than the remaining " +
                  std::to_string(bytesLeft) + " bytes can hold");
    }
    blockDeclared_ = static_cast<std::uint64_t>(declared);
    pointsLeftInBlock_ = blockDeclared_;
    blockLine_ = lines_.lineNumber();
  }

  std::string blockShortfall() const {
    return "the count on line " + std::to_string(blockLine_) + " declares " + std::to_string(blockDeclared_) +
           " points, found " + std::to_string(blockDeclared_ - pointsLeftInBlock_);
  }

  ColumnLayout detectLayout() {
    std::string_view line;
    if (!nextPointLine(line)) return ColumnLayout{kX, kY, kZ};
    std::vector<std::string_view> none;
    firstPoint_ = line;
    firstPointPending_ = true;
    return ptsLayout(splitFields(line, none));
  }

  TextLines lines_;
  std::vector<std::string_view> leadingFields_ = std::vector<std::string_view>(1);  // enough to spot a count line
  std::uint64_t blockDeclared_ = 0;
  std::uint64_t pointsLeftInBlock_ = 0;
  std::uint64_t blockLine_ = 0;  // line of the current block's count; 0 before the first count
  std::string firstPoint_;
  bool firstPointPending_ = false;
  PointLineParser parser_;
  CloudInfo info_;
};

}  // namespace

std::unique_ptr<PointReader> openXyzReader(const std::filesystem::path& path) {
  return std::make_unique<XyzReader>(path);
}

std::unique_ptr<PointReader> openPtsReader(const std::filesystem::path& path) {
  return std::make_unique<PtsReader>(path);
}

}  // namespace piperun::io
