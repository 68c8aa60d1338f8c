#include "nearest_neighbors.h"

#include "angles.h"
#include "bounds.h"
#include "cell_table.h"
#include "sort_by_key.h"

#include "piperun/point_cloud.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>

namespace piperun {
namespace {

/// k neighbours on a surface fill a disc of radius ≈ spacing · √(k / π); the finest cells are this
/// many such radii wide, so the 3 × 3 × 3 block around most points holds all their neighbours.
constexpr double kEdgePerNeighborRadius = 1.6;
/// Each coarser level's cells are this many times wider than the level below.
constexpr double kLevelRatio = 6.0;
/// Beyond this many cells across a search moves to the next coarser level: a block of that many
/// squared rows costs more than a level's grid.
constexpr std::int64_t kMaxBlockCells = 17;
/// Cells per parallel task; fixed, so the work split does not depend on the thread count.
constexpr std::size_t kCellsPerChunk = 256;
/// Cells per axis at most, so keys (x · ny + y) · nz + z fit 63 bits.
constexpr double kMaxCellsPerAxis = 1 << 20;

/// The rows of a grid are indexed in a table of every row when there are at most this many per point
/// (4 bytes each), by hashing the occupied ones otherwise.
constexpr std::uint64_t kMaxRowSlotsPerPoint = 4;

/// Up to this many candidates the k nearest are placed by rank (quadratic, branch-free), beyond
/// it by a partial sort.
constexpr std::size_t kMaxRanked = 48;

using Cube = Eigen::Array<std::int64_t, 3, 1>;

/// Cubic cells of one edge, counted from the low corner of the points' bounds, and the points in
/// each occupied cell.
class CellGrid {
 public:
  CellGrid(const std::vector<Eigen::Vector3f>& positions, const BoundingBox& bounds, double edge)
      : low_(bounds.min), edge_(std::max(edge, bounds.size().maxCoeff() / kMaxCellsPerAxis)) {
    if (!(edge_ > 0.0)) edge_ = 1.0;  // all points coincide: one cell
    counts_ = ((bounds.max - low_) / edge_).array().floor().cast<std::int64_t>() + 1;
    cells_ = groupItemsByKey(positions.size(), [&](std::size_t i) { return keyOf(positions[i]); });
    const std::size_t n = cells_.items.size();
    x_.resize(n);
    y_.resize(n);
    z_.resize(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      const Eigen::Vector3f& p = positions[cells_.items[i]];
      x_[i] = p.x();
      y_[i] = p.y();
      z_[i] = p.z();
    });
    indexRows();
  }

  double edge() const { return edge_; }

  /// Every point, grouped by cell in key order.
  const KeyGroups& cells() const { return cells_; }

  std::uint64_t keyOf(const Eigen::Vector3f& p) const { return key(cubeOf(p)); }
  /// The cube holding p + offset on every axis (not clipped to the grid).
  Cube cubeOfOffset(const Eigen::Vector3f& p, double offset) const {
    return ((p.cast<double>().array() + offset - low_.array()) / edge_).floor().cast<std::int64_t>();
  }
  Cube cubeOfKey(std::uint64_t k) const {
    const auto ny = static_cast<std::uint64_t>(counts_.y()), nz = static_cast<std::uint64_t>(counts_.z());
    return Cube(static_cast<std::int64_t>(k / (ny * nz)), static_cast<std::int64_t>(k / nz % ny),
                static_cast<std::int64_t>(k % nz));
  }

  /// Cells [first, last) of a row (x, y); empty when no cell of the row is occupied.
  struct Row {
    std::uint32_t first = 0, last = 0;
  };

  /// The points in the cells from cube `from` to cube `to` (inclusive, per axis; clipped to the
  /// grid): ranges of the cell-ordered arrays, one per row of cells.
  struct Block {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> ranges;
    std::size_t count = 0;
    // The rows of the last block: cells are visited along z, so the next block often spans them too.
    Eigen::Array4i rowSpan = Eigen::Array4i::Constant(-1);  // first x, first y, last x, last y
    std::vector<Row> rows;
  };

  void gatherBlock(const Cube& from, const Cube& to, Block& out) const {
    out.ranges.clear();
    out.count = 0;
    const Cube first = from.max(0);
    const Cube last = to.min(counts_ - 1);
    const Eigen::Array4i span(static_cast<int>(first.x()), static_cast<int>(first.y()), static_cast<int>(last.x()),
                              static_cast<int>(last.y()));
    if ((span != out.rowSpan).any()) {
      out.rowSpan = span;
      out.rows.clear();
      for (std::int64_t x = first.x(); x <= last.x(); ++x) {
        for (std::int64_t y = first.y(); y <= last.y(); ++y) {
          out.rows.push_back(findRow(static_cast<std::uint64_t>(x) * static_cast<std::uint64_t>(counts_.y()) +
                                     static_cast<std::uint64_t>(y)));
        }
      }
    }
    // A row (x, y) holds consecutive keys along z: its cells from first.z to last.z are one range
    // of the cell-ordered arrays, found by a short search within the row.
    const auto nz = static_cast<std::uint64_t>(counts_.z());
    for (const Row& row : out.rows) {
      if (row.first == row.last) continue;
      const auto rowFirst = cells_.keys.begin() + row.first, rowLast = cells_.keys.begin() + row.last;
      const std::uint64_t rowStart = *rowFirst / nz * nz;
      const auto cellFirst = std::lower_bound(rowFirst, rowLast, rowStart + static_cast<std::uint64_t>(first.z()));
      const auto cellLast = std::upper_bound(cellFirst, rowLast, rowStart + static_cast<std::uint64_t>(last.z()));
      if (cellFirst == cellLast) continue;
      const std::uint32_t from = cells_.begins[static_cast<std::size_t>(cellFirst - cells_.keys.begin())];
      const std::uint32_t to = cells_.begins[static_cast<std::size_t>(cellLast - cells_.keys.begin())];
      out.ranges.emplace_back(from, to);
      out.count += to - from;
    }
  }

  /// Point indices and coordinates in cell order, the arrays a Block's ranges refer to.
  const std::uint32_t* orderedPoints() const { return cells_.items.data(); }
  const float* orderedX() const { return x_.data(); }
  const float* orderedY() const { return y_.data(); }
  const float* orderedZ() const { return z_.data(); }

  /// Distance from `p` to the nearest face of the block of cubes `from`..`to` through which a point
  /// could lie outside it (faces on the grid's border hide nothing, so a block over the whole grid
  /// has infinite clearance).
  double clearance(const Eigen::Vector3f& p, const Cube& from, const Cube& to) const {
    double nearest = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
      const double x = static_cast<double>(p[axis]) - low_[axis];
      if (from[axis] > 0) nearest = std::min(nearest, x - static_cast<double>(from[axis]) * edge_);
      if (to[axis] < counts_[axis] - 1) nearest = std::min(nearest, static_cast<double>(to[axis] + 1) * edge_ - x);
    }
    return nearest - 1e-6 * edge_;  // the rounding of a point on a face into either cell must not matter
  }

 private:
  Cube cubeOf(const Eigen::Vector3f& p) const {
    return ((p.cast<double>() - low_) / edge_).array().floor().cast<std::int64_t>().max(0).min(counts_ - 1);
  }
  std::uint64_t key(const Cube& c) const {
    return (static_cast<std::uint64_t>(c.x()) * static_cast<std::uint64_t>(counts_.y()) + static_cast<std::uint64_t>(c.y())) *
               static_cast<std::uint64_t>(counts_.z()) +
           static_cast<std::uint64_t>(c.z());
  }

  /// The cells of each row (x · ny + y) that has any, found by row number: through a table of every
  /// row when it takes no more than kMaxRowSlotsPerPoint entries per point (one read per row, where a
  /// hash probe missed the cache; blocks look up nine rows whenever they move to the next row),
  /// otherwise through a hash table of the occupied rows.
  void indexRows() {
    const auto nz = static_cast<std::uint64_t>(counts_.z());
    const auto rowCount = static_cast<std::uint64_t>(counts_.x()) * static_cast<std::uint64_t>(counts_.y());
    const bool dense = rowCount <= kMaxRowSlotsPerPoint * std::max<std::uint64_t>(cells_.items.size(), 1);
    if (dense) rowSlots_.assign(static_cast<std::size_t>(rowCount), 0);
    for (std::size_t c = 0; c < cells_.keys.size();) {
      const std::uint64_t row = cells_.keys[c] / nz;
      std::size_t end = c + 1;
      while (end < cells_.keys.size() && cells_.keys[end] / nz == row) ++end;
      if (dense) {
        rowSlots_[static_cast<std::size_t>(row)] = static_cast<std::uint32_t>(rows_.size() + 1);
      } else {
        rowIds_.insert(row);  // ids follow the rows, in order
      }
      rows_.push_back({static_cast<std::uint32_t>(c), static_cast<std::uint32_t>(end)});
      c = end;
    }
  }

  Row findRow(std::uint64_t row) const {
    if (!rowSlots_.empty()) {
      const std::uint32_t slot = rowSlots_[static_cast<std::size_t>(row)];
      return slot == 0 ? Row{} : rows_[slot - 1];
    }
    const std::int64_t id = rowIds_.find(row);
    return id < 0 ? Row{} : rows_[static_cast<std::size_t>(id)];
  }

  Eigen::Vector3d low_;
  double edge_;
  Cube counts_;
  KeyGroups cells_;                   // the points by cell
  std::vector<float> x_, y_, z_;       // their coordinates, in the same order
  std::vector<std::uint32_t> rowSlots_;  // row number → index into rows_ + 1 (0: no cell), when dense...
  CellTable rowIds_;                   // ...otherwise row number → index into rows_
  std::vector<Row> rows_;              // the cells of each occupied row
};

/// Scratch space of one task: a block's candidates side by side, their squared distances to one
/// point and the nearest of them.
struct Scratch {
  std::vector<std::uint32_t> open;
  CellGrid::Block block;
  std::vector<float> x, y, z;              // the block's candidates, copied out of its ranges...
  std::vector<std::uint32_t> point;        // ...and their point indices
  std::vector<float> squared;              // squared distances to the point searched for
  std::vector<std::uint32_t> near;         // the candidates within the threshold, by position in the block
  std::vector<float> nearSquared;          // their squared distances...
  std::vector<std::uint32_t> nearPoint;    // ...and point indices
  std::vector<float> rankedSquared;        // the k + 1 nearest of them (the point itself among them)...
  std::vector<std::uint32_t> rankedPoint;  // ...in order
  std::vector<std::uint64_t> order;        // (squared distance, point) packed, for a partial sort
  float guess = 0.0f;  ///< Squared k-th distance of the task's last point: its neighbours' is alike.

  /// Copies the block's candidates side by side: every point of the cell reads them.
  void loadBlock(const CellGrid& grid) {
    const std::size_t count = block.count;
    x.resize(count);
    y.resize(count);
    z.resize(count);
    point.resize(count);
    std::size_t b = 0;
    for (const auto& [from, to] : block.ranges) {
      const std::size_t length = to - from;
      std::copy_n(grid.orderedX() + from, length, x.begin() + static_cast<std::ptrdiff_t>(b));
      std::copy_n(grid.orderedY() + from, length, y.begin() + static_cast<std::ptrdiff_t>(b));
      std::copy_n(grid.orderedZ() + from, length, z.begin() + static_cast<std::ptrdiff_t>(b));
      std::copy_n(grid.orderedPoints() + from, length, point.begin() + static_cast<std::ptrdiff_t>(b));
      b += length;
    }
  }
};

/// (squared distance, point) packed so that integer order is (distance, index) order: the bits of
/// a non-negative float order as the float does.
std::uint64_t packed(float squared, std::uint32_t point) {
  std::uint32_t bits;
  std::memcpy(&bits, &squared, sizeof bits);
  return (static_cast<std::uint64_t>(bits) << 32) | point;
}
float squaredOf(std::uint64_t packedValue) {
  const auto bits = static_cast<std::uint32_t>(packedValue >> 32);
  float squared;
  std::memcpy(&squared, &bits, sizeof squared);
  return squared;
}

/// What a search among a block found for a point that it could not settle.
struct Unsettled {
  bool enough = false;  ///< The block held k candidates...
  double kth = 0.0;     ///< ...the k-th of them this far away: the true k-th is no farther.
};

/// Searches point i's neighbours among the loaded block. Visits its list and returns nothing when
/// the k-th is nearer than `clearance`; otherwise returns what it found.
std::optional<Unsettled> trySettle(std::uint32_t i, const Eigen::Vector3f& q, const CellGrid& grid, Scratch& s,
                                   double clearance, std::size_t k, const NeighborVisitor& visit) {
  const std::size_t count = s.block.count;
  if (count < k + 1) return Unsettled{};  // the point itself is among the candidates
  s.squared.resize(count);
  {
    const float* __restrict x = s.x.data();
    const float* __restrict y = s.y.data();
    const float* __restrict z = s.z.data();
    float* __restrict squared = s.squared.data();
    const float qx = q.x(), qy = q.y(), qz = q.z();
    for (std::size_t b = 0; b < count; ++b) {
      const float dx = x[b] - qx, dy = y[b] - qy, dz = z[b] - qz;
      squared[b] = dx * dx + dy * dy + dz * dz;
    }
  }
  // A threshold that lets between k and 1.4 k candidates in besides the point itself (the ranking
  // below costs their count squared): from the last point's k-th distance, corrected as on a
  // surface (the count grows with the squared radius). Counting and collecting without branches is
  // much cheaper than selecting among all candidates.
  float threshold = s.guess > 0.0f ? 1.05f * s.guess : static_cast<float>(grid.edge() * grid.edge());
  for (int attempt = 0;; ++attempt) {
    std::uint32_t within = 0;  // 32 bits: four lanes at a time
    for (std::size_t b = 0; b < count; ++b) within += s.squared[b] <= threshold;
    --within;  // the point itself, at distance 0
    if (within >= k && (10 * within <= 14 * k || attempt >= 8)) break;
    const float scale = within == 0 ? 4.0f : std::clamp(1.2f * static_cast<float>(k) / static_cast<float>(within), 0.25f, 4.0f);
    threshold *= scale;
  }
  s.near.resize(count);
  std::size_t kept = 0;
  for (std::size_t b = 0; b < count; ++b) {
    s.near[kept] = static_cast<std::uint32_t>(b);
    kept += static_cast<std::size_t>(s.squared[b] <= threshold);
  }
  s.nearSquared.resize(kept);
  s.nearPoint.resize(kept);
  for (std::size_t a = 0; a < kept; ++a) {
    s.nearSquared[a] = s.squared[s.near[a]];
    s.nearPoint[a] = s.point[s.near[a]];
  }
  // The k + 1 smallest in (distance, index) order, placed by rank: the pairs are distinct, and
  // counting without branches (several lanes at a time) beats a sort's unpredictable branches on a
  // few dozen values.
  const std::size_t ranks = k + 1;
  s.rankedSquared.resize(ranks);
  s.rankedPoint.resize(ranks);
  if (kept <= kMaxRanked) {
    const float* __restrict squared = s.nearSquared.data();
    const std::uint32_t* __restrict point = s.nearPoint.data();
    for (std::size_t a = 0; a < kept; ++a) {
      const float da = squared[a];
      const std::uint32_t pa = point[a];
      std::uint32_t rank = 0;
      for (std::size_t c = 0; c < kept; ++c) {
        rank += static_cast<std::uint32_t>(squared[c] < da) |
                (static_cast<std::uint32_t>(squared[c] == da) & static_cast<std::uint32_t>(point[c] < pa));
      }
      if (rank < ranks) {
        s.rankedSquared[rank] = da;
        s.rankedPoint[rank] = pa;
      }
    }
  } else {
    std::vector<std::uint64_t>& order = s.order;
    order.resize(kept);
    for (std::size_t a = 0; a < kept; ++a) order[a] = packed(s.nearSquared[a], s.nearPoint[a]);
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(ranks), order.end());
    for (std::size_t j = 0; j < ranks; ++j) {
      s.rankedSquared[j] = squaredOf(order[j]);
      s.rankedPoint[j] = static_cast<std::uint32_t>(order[j]);
    }
  }
  // The point itself leaves the list (first, unless it has copies of lower index).
  const auto self = std::find(s.rankedPoint.begin(), s.rankedPoint.end(), i);
  if (self != s.rankedPoint.end()) {
    s.rankedSquared.erase(s.rankedSquared.begin() + (self - s.rankedPoint.begin()));
    s.rankedPoint.erase(self);
  }
  const float kth = s.rankedSquared[k - 1];
  s.guess = kth;
  if (static_cast<double>(kth) > clearance * clearance) return Unsettled{true, std::sqrt(static_cast<double>(kth))};
  visit(i, s.rankedPoint.data(), s.rankedSquared.data());
  return std::nullopt;
}

/// Settles the points [first, last) of one cell of `grid`: blocks around the cell are gathered once
/// for the points still open, each next block grown on the sides where an open point's k-th found
/// so far reaches past the faces (then it settles there), or doubled where a point found fewer than
/// k. Appends the points whose block would grow past kMaxBlockCells to `unsettled`.
void settleCell(const CellGrid& grid, const Cube& centre, const std::uint32_t* first, const std::uint32_t* last,
                const std::vector<Eigen::Vector3f>& positions, Scratch& s, std::size_t k, const NeighborVisitor& visit,
                std::vector<std::uint32_t>& unsettled) {
  std::vector<std::uint32_t>& points = s.open;
  points.assign(first, last);
  Cube from = centre - 1, to = centre + 1;
  while (!points.empty()) {
    if ((to - from + 1 > kMaxBlockCells).any()) {
      unsettled.insert(unsettled.end(), points.begin(), points.end());
      return;
    }
    grid.gatherBlock(from, to, s.block);
    s.loadBlock(grid);
    Cube nextFrom = from, nextTo = to;
    std::size_t open = 0;
    for (const std::uint32_t i : points) {
      const Eigen::Vector3f& q = positions[i];
      const std::optional<Unsettled> result = trySettle(i, q, grid, s, grid.clearance(q, from, to), k, visit);
      if (!result) continue;
      if (result->enough) {
        // Grow each side the sphere of the k-th found crosses, by the cells it crosses into.
        const Cube reachFrom = grid.cubeOfOffset(q, -result->kth), reachTo = grid.cubeOfOffset(q, result->kth);
        nextFrom = nextFrom.min(reachFrom - 1);
        nextTo = nextTo.max(reachTo + 1);
      } else {
        nextFrom = nextFrom.min(from - (to - from + 1));
        nextTo = nextTo.max(to + (to - from + 1));
      }
      points[open++] = i;
    }
    points.resize(open);
    from = nextFrom;
    to = nextTo;
  }
}

}  // namespace

int neighborListSize(std::size_t points, int k) {
  return points < 2 ? 0 : static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(std::max(k, 0)), points - 1));
}

void visitNearestNeighbors(const std::vector<Eigen::Vector3f>& positions, int k, double spacing, Progress& progress,
                           const char* task, double progressFrom, double progressTo, const NeighborVisitor& visit) {
  const std::size_t n = positions.size();
  const auto listSize = static_cast<std::size_t>(neighborListSize(n, k));
  if (listSize == 0) return;
  const auto [bounds, finite] = finiteBounds(positions);
  // A non-finite point is at no distance from anything: its search would never settle.
  if (finite != n) throw std::invalid_argument("visitNearestNeighbors: every position must be finite");

  const double neighborRadius = spacing * std::sqrt(static_cast<double>(listSize) / kPi);
  double edge = kEdgePerNeighborRadius * neighborRadius;

  // Level by level: the points a level leaves open (sparse regions, outliers) go to wider cells.
  std::vector<std::uint32_t> open;
  std::atomic<std::size_t> settled{0};
  for (bool finest = true; finest || !open.empty(); finest = false, edge *= kLevelRatio) {
    progress.checkCancelled();
    const CellGrid grid(positions, bounds, edge);
    // The open points grouped by this level's cells: at the finest level all of them, as the grid
    // groups them.
    KeyGroups openGroups;
    if (!finest) {
      std::vector<KeyedItem> keyed(open.size());
      for (std::size_t e = 0; e < open.size(); ++e) keyed[e] = {grid.keyOf(positions[open[e]]), open[e]};
      std::sort(keyed.begin(), keyed.end());
      openGroups = groupByKey(keyed);
    }
    const KeyGroups& groups = finest ? grid.cells() : openGroups;
    const std::vector<std::uint32_t>& points = groups.items;
    const std::vector<std::uint64_t>& keys = groups.keys;
    const std::vector<std::uint32_t>& begins = groups.begins;

    const std::size_t cells = keys.size();
    const std::size_t chunks = (cells + kCellsPerChunk - 1) / kCellsPerChunk;
    std::vector<std::vector<std::uint32_t>> openPerChunk(chunks);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t chunk) {
      progress.checkCancelled();
      Scratch scratch;
      const std::size_t lastCell = std::min(cells, (chunk + 1) * kCellsPerChunk);
      for (std::size_t c = chunk * kCellsPerChunk; c < lastCell; ++c) {
        settleCell(grid, grid.cubeOfKey(keys[c]), points.data() + begins[c], points.data() + begins[c + 1], positions,
                   scratch, listSize, visit, openPerChunk[chunk]);
      }
      const std::size_t done = begins[lastCell] - begins[chunk * kCellsPerChunk] - openPerChunk[chunk].size();
      const std::size_t total = settled.fetch_add(done) + done;
      progress.report(task, progressFrom + (progressTo - progressFrom) * static_cast<double>(total) / static_cast<double>(n));
    });
    open.clear();
    for (const auto& part : openPerChunk) open.insert(open.end(), part.begin(), part.end());
  }
}

}  // namespace piperun
