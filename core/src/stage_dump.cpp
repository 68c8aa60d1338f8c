#include "piperun/stage_dump.h"

#include "piperun/error.h"
#include "piperun/io/point_writer.h"

#include <string>

namespace piperun {

namespace {

PointChunk labelledPoints(const PointCloud& cloud, const std::vector<std::uint32_t>& indices, std::int32_t label) {
  PointChunk chunk;
  for (std::uint32_t i : indices) {
    chunk.positions.push_back(cloud.worldPosition(i));
    chunk.labels.push_back(label);
  }
  return chunk;
}

void append(PointChunk& target, const PointChunk& source) {
  target.positions.insert(target.positions.end(), source.positions.begin(), source.positions.end());
  target.labels.insert(target.labels.end(), source.labels.begin(), source.labels.end());
}

void writeChunk(const std::filesystem::path& path, const PointChunk& chunk, int& files) {
  auto writer = openPlyWriter(path, chunk.attributes());
  writer->write(chunk);
  writer->close();
  ++files;
}

void createDirectories(const std::filesystem::path& directory) {
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) throw OutputError(directory, "cannot create the folder: " + error.message());
}

}  // namespace

int dumpStages(const Pipeline& pipeline, const std::filesystem::path& directory) {
  createDirectories(directory);
  int files = 0;
  const auto prepared = pipeline.preprocessResult();
  if (!prepared) return files;
  const PointCloud& cloud = prepared->points;
  writePointCloud(directory / "preprocessed.ply", cloud);
  ++files;
  if (!prepared->planePoints.empty()) {
    writePointCloud(directory / "planes.ply", prepared->planePoints);
    ++files;
  }

  if (const auto tiles = pipeline.tileResults()) {
    for (const auto& tile : *tiles) {
      for (std::size_t r = 0; r < tile.rounds.size(); ++r) {
        const TileRound& round = tile.rounds[r];
        const auto folder = directory / ("tile_" + std::to_string(tile.tileId)) / ("round_" + std::to_string(r));
        createDirectories(folder);

        // A point in several stripes is written once per stripe.
        PointChunk directions = labelledPoints(cloud, round.points, -1);
        for (std::size_t k = 0; k < round.directions.directions.size(); ++k) {
          append(directions, labelledPoints(cloud, round.directions.directions[k].stripe, static_cast<int>(k)));
        }
        writeChunk(folder / "directions.ply", directions, files);

        PointChunk samples;
        for (std::size_t s = 0; s < round.directions.samples.size(); ++s) {
          samples.positions.push_back(round.directions.samples[s].cast<double>());
          samples.labels.push_back(round.directions.sampleDirection[s]);
        }
        if (!samples.empty()) writeChunk(folder / "sphere_samples.ply", samples, files);

        for (std::size_t k = 0; k < round.placement.projections.size(); ++k) {
          PointChunk candidates;
          for (const auto& candidate : round.placement.projections[k].candidates) {
            candidates.positions.emplace_back(candidate.center.x(), candidate.center.y(), candidate.radius);
            candidates.labels.push_back(candidate.circle);
          }
          if (!candidates.empty()) writeChunk(folder / ("candidates_" + std::to_string(k) + ".ply"), candidates, files);
        }

        PointChunk cylinders;
        for (std::size_t c = 0; c < round.placement.cylinders.size(); ++c) {
          append(cylinders, labelledPoints(cloud, round.placement.cylinders[c].inliers, static_cast<int>(c)));
        }
        if (!cylinders.empty()) writeChunk(folder / "cylinders.ply", cylinders, files);
      }
    }
  }

  // Labels are the network's ids: those of the joints stage when it ran (fragments it absorbed
  // are gone), else of the merge.
  const auto joints = pipeline.isFresh(Stage::Joints) ? pipeline.jointsResult() : nullptr;
  const auto merged = pipeline.mergeResult();
  if (joints || merged) {
    const std::vector<PipeSegment>& segments = joints ? joints->pipes : merged->segments;
    PointChunk pipes;
    for (std::size_t p = 0; p < segments.size(); ++p) {
      append(pipes, labelledPoints(cloud, segments[p].inliers, static_cast<int>(p + 1)));
    }
    if (!pipes.empty()) writeChunk(directory / "pipes.ply", pipes, files);
  }
  if (joints) {
    PointChunk support;
    for (std::size_t j = 0; j < joints->joints.size(); ++j) {
      append(support, labelledPoints(cloud, joints->jointSupport[j], joints->joints[j].id));
    }
    if (!support.empty()) writeChunk(directory / "joints.ply", support, files);
  }
  return files;
}

}  // namespace piperun
