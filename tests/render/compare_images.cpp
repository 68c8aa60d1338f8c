// compare-images OUTPUT BASELINE DIFF THRESHOLD: compares two PNGs with vtkImageDifference, which
// tolerates small colour errors and pixels shifted by a little (anti-aliased text, rasterisation
// order). The error is the share of pixels that still differ; above THRESHOLD the difference image
// is written to DIFF and the exit code is 1.

#include <vtkImageData.h>
#include <vtkImageDifference.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPNGWriter.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

bool readPng(const char* path, vtkPNGReader* reader) {
  if (!reader->CanReadFile(path)) {
    std::fprintf(stderr, "compare-images: %s: not a readable PNG\n", path);
    return false;
  }
  reader->SetFileName(path);
  reader->Update();
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::fprintf(stderr, "usage: compare-images OUTPUT.png BASELINE.png DIFF.png THRESHOLD\n");
    return 2;
  }
  vtkNew<vtkPNGReader> output, baseline;
  if (!readPng(argv[1], output) || !readPng(argv[2], baseline)) return 2;
  int outputSize[3], baselineSize[3];
  output->GetOutput()->GetDimensions(outputSize);
  baseline->GetOutput()->GetDimensions(baselineSize);
  if (outputSize[0] != baselineSize[0] || outputSize[1] != baselineSize[1]) {
    std::fprintf(stderr, "compare-images: %s is %dx%d, the baseline %s is %dx%d\n", argv[1], outputSize[0],
                 outputSize[1], argv[2], baselineSize[0], baselineSize[1]);
    return 1;
  }
  vtkNew<vtkImageDifference> difference;
  difference->SetInputConnection(output->GetOutputPort());
  difference->SetImageConnection(baseline->GetOutputPort());
  difference->Update();
  vtkImageData* differences = difference->GetOutput();
  const vtkIdType pixels = static_cast<vtkIdType>(outputSize[0]) * outputSize[1];
  const int channels = differences->GetNumberOfScalarComponents();
  const auto* values = static_cast<const unsigned char*>(differences->GetScalarPointer());
  vtkIdType differing = 0;
  for (vtkIdType i = 0; i < pixels; ++i)
    differing += std::any_of(values + i * channels, values + (i + 1) * channels, [](unsigned char v) { return v > 0; });
  const double error = static_cast<double>(differing) / static_cast<double>(pixels);
  const double threshold = std::atof(argv[4]);
  std::printf("error %.6f (threshold %.6f) %s vs %s\n", error, threshold, argv[1], argv[2]);
  if (error <= threshold) return 0;
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(argv[3]);
  writer->SetInputConnection(difference->GetOutputPort());
  writer->Write();
  std::fprintf(stderr, "compare-images: images differ; output %s, difference %s\n", argv[1], argv[3]);
  return 1;
}
