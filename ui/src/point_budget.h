#pragma once
// Which points of a site-sized point layer the 3-D scene draws when the camera is still: at most a
// budget, only those in view, the near ones densest. A scan of a hundred million points then draws
// about as fast as a room's, and zooming in brings back every point of what is in view.

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace piperun::ui {

/// A layer's points filed by cubic cell, each cell's points in a fixed pseudo-random order, so that
/// the first k points of a cell are an even subsample of it.
struct PointCells {
  struct Cell {
    Eigen::Vector3f min = Eigen::Vector3f::Zero();  ///< Bounds of the cell's points.
    Eigen::Vector3f max = Eigen::Vector3f::Zero();
    std::uint32_t begin = 0;  ///< The cell's points: order[begin, end).
    std::uint32_t end = 0;
  };
  std::vector<Cell> cells;
  std::vector<std::uint32_t> order;  ///< Point indices, cell by cell; non-finite points are left out.
};

/// Files `positions` (at most 2^32 - 1 of them) by cubic cells of a 128th of their bounds' longest
/// side, at least `minCell` (m). Parallel; the result depends only on the positions.
PointCells filePointCells(const std::vector<Eigen::Vector3f>& positions, float minCell = 0.25f);

/// A camera's view for choosing points: the planes bounding what can be seen (n.p + d >= 0 inside:
/// its frustum's four sides, the faces of a clip) and, for a perspective camera, its eye.
struct ViewVolume {
  std::vector<Eigen::Vector4d> planes;
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();
  bool perspective = true;
};

/// How many of each cell's first points to draw, `budget` at most in all. Given a view: none of the
/// cells wholly outside one of its planes, and of the others a share falling with the square of the cell's distance
/// from the eye (about as many points per pixel near as far), the largest shares that fit; every
/// point in view when they all fit. Without a view: the same share of every cell.
std::vector<std::uint32_t> pointsToDraw(const PointCells& cells, const ViewVolume* view, std::size_t budget);

}  // namespace piperun::ui
