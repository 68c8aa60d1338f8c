#pragma once
// The stage bar: one VTK button per pipeline stage showing fresh / stale / running, and a slider
// for the selected stage's main parameter. Generic over kAllStages, so new stages appear by themselves.

#include "piperun/pipeline.h"

#include <vtkSmartPointer.h>

#include <functional>
#include <string>
#include <vector>

class vtkButtonWidget;
class vtkRenderer;
class vtkRenderWindowInteractor;
class vtkSliderWidget;

namespace piperun::ui {

enum class StageState { Stale, Fresh, Running };

/// The parameter the slider edits for a stage, with its range.
struct StageParameter {
  std::string key;  ///< As setParam takes it: "placement.center_bandwidth".
  double minimum = 0.0;
  double maximum = 1.0;
};

/// The main parameter of `stage`, if it has one the slider can edit.
const StageParameter* mainParameter(Stage stage);

class StageBar {
 public:
  /// `onStage` runs when a stage button is clicked, `onParameter` when the slider is released.
  StageBar(vtkRenderWindowInteractor* interactor, vtkRenderer* overlay, std::function<void(Stage)> onStage,
           std::function<void(const std::string& key, double value)> onParameter);
  ~StageBar();

  void setEnabled(bool enabled);
  bool enabled() const { return enabled_; }
  void setStates(const std::vector<StageState>& states);
  /// Shows `stage` as selected and points the slider at its main parameter (hidden if it has none).
  void setSelected(Stage stage, double parameterValue);
  /// Places the buttons along the bottom of a window of this size (pixels), `height` pixels tall.
  void layout(int windowWidth, int barHeight, double scale);

 private:
  struct Button {
    Stage stage;
    vtkSmartPointer<vtkButtonWidget> widget;
  };
  void applyStates();

  vtkRenderWindowInteractor* interactor_;
  vtkRenderer* overlay_;
  std::function<void(Stage)> onStage_;
  std::function<void(const std::string&, double)> onParameter_;
  std::vector<Button> buttons_;
  std::vector<StageState> states_;
  vtkSmartPointer<vtkSliderWidget> slider_;
  Stage selected_ = Stage::Preprocess;
  bool enabled_ = false;
  bool sliderShown_ = false;
  int faceWidth_ = 96, faceHeight_ = 28;  ///< Button face size in pixels (the faces carry the labels).
  double scale_ = 1.0;
};

}  // namespace piperun::ui
