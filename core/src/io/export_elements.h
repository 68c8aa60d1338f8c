#pragma once
// What every network export writes: the elements that are kept, in one flat list, and the
// per-format document writers (network_export.cpp picks one and writes the file atomically).

#include "piperun/edit/nominal_sizes.h"
#include "piperun/io/network_export.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace piperun::io {

/// Element types as stored in PLY's per-face `element_type`.
enum class ElementKind : std::uint8_t { Pipe = 0, Elbow = 1, Tee = 2, Boundary = 3 };

/// "pipe", "elbow", "tee", "boundary".
const char* kindName(ElementKind kind);

struct ExportElement {
  ElementKind kind = ElementKind::Pipe;
  int id = 0;                         ///< Pipe id or joint id (separate id spaces).
  std::string name;                   ///< "pipe-12", "elbow-3": unique within a network.
  double radius = 0.0;                ///< Metres.
  std::vector<Eigen::Vector3d> axis;  ///< Centre line: a pipe's {start, end}, a joint's axis.
  double bendRadius = 0.0;            ///< Elbows; 0 otherwise.
  double confidence = 0.0;
  std::string status;                 ///< "accepted" or "proposed".
  int runId = -1;                     ///< -1 when the element is in no run.
  const Joint* joint = nullptr;       ///< The joint this element is (nullptr for a pipe).

  double length() const;
};

/// The pipes that are not deleted, then the joints that are not rejected, in network order. An
/// element's run is the run listing it; a pipe listed by no run keeps its own runId.
std::vector<ExportElement> exportedElements(const PipeNetwork& network);

/// The shortest decimal text that reads back as exactly `value`.
std::string shortestNumber(double value);

// Document writers, one per format (export_<format>.cpp).
std::string objDocument(const std::vector<ExportElement>& elements, const ExportOptions& options);
std::string plyDocument(const std::vector<ExportElement>& elements, const ExportOptions& options);
/// Heights along `up`, in the network's co-ordinates.
std::string csvDocument(const std::vector<ExportElement>& elements, const NominalSizes& sizes, UpAxis up);
std::string dxfDocument(const std::vector<ExportElement>& elements);
/// `nominal`: the table of nominal bores; nullptr: the fitted outside diameters.
std::string pcfDocument(const std::vector<ExportElement>& elements, const NominalSizes* nominal);
/// `fileName` is recorded in the file's header.
std::string ifcDocument(const std::vector<ExportElement>& elements, const NominalSizes& sizes,
                        const std::string& fileName);

}  // namespace piperun::io
