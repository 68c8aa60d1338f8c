#include "stage_bar.h"

#include "observe.h"
#include "palette.h"

#include <vtkButtonWidget.h>
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkImageData.h>
#include <vtkProperty2D.h>
#include <vtkRenderer.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkSliderRepresentation2D.h>
#include <vtkSliderWidget.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkTexturedButtonRepresentation2D.h>

#include <array>

namespace piperun::ui {

namespace {

const std::array<StageParameter, 5> kMainParameters{{{"preprocess.voxel_size", 0.003, 0.05},
                                                         {"directions.bandwidth_deg", 0.5, 10.0},
                                                         {"placement.center_bandwidth", 0.002, 0.05},
                                                         {"extents.section_length", 0.01, 0.2},
                                                         {"merge.max_gap", 0.0, 0.5}}};

/// A flat button face with a darker border; `selected` draws a light border instead.
vtkSmartPointer<vtkImageData> buttonFace(Rgb fill, bool selected) {
  constexpr int kWidth = 96, kHeight = 28, kBorder = 2;  // The aspect of the buttons (96 x 28 at scale 1).
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(kWidth, kHeight, 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      auto* pixel = static_cast<unsigned char*>(image->GetScalarPointer(x, y, 0));
      const bool border = x < kBorder || y < kBorder || x >= kWidth - kBorder || y >= kHeight - kBorder;
      for (int c = 0; c < 3; ++c)
        pixel[c] = !border ? fill[c] : selected ? 255 : static_cast<unsigned char>(fill[c] / 2);
    }
  return image;
}

constexpr Rgb kStaleFill{90, 90, 96};
constexpr Rgb kFreshFill{40, 130, 70};
constexpr Rgb kRunningFill{200, 130, 20};

}  // namespace

const StageParameter* mainParameter(Stage stage) {
  for (const auto& parameter : kMainParameters)
    if (parameter.key.rfind(std::string(stageName(stage)) + ".", 0) == 0) return &parameter;
  return nullptr;
}

StageBar::StageBar(vtkRenderWindowInteractor* interactor, vtkRenderer* overlay, std::function<void(Stage)> onStage,
                   std::function<void(const std::string&, double)> onParameter)
    : interactor_(interactor), overlay_(overlay), onStage_(std::move(onStage)), onParameter_(std::move(onParameter)) {
  for (Stage stage : kAllStages) {
    Button button{stage, vtkSmartPointer<vtkButtonWidget>::New(), vtkSmartPointer<vtkTextActor>::New()};
    auto representation = vtkSmartPointer<vtkTexturedButtonRepresentation2D>::New();
    representation->SetNumberOfStates(3);
    representation->SetPlaceFactor(1.0);  // The default 0.5 would shrink the button inside its bounds.
    button.widget->SetInteractor(interactor_);
    button.widget->SetCurrentRenderer(overlay_);
    button.widget->SetRepresentation(representation);
    // A click advances the button's own state; the bar shows the pipeline's instead.
    observe(button.widget, vtkCommand::StateChangedEvent, [this, stage](vtkObject*, unsigned long, void*) {
      applyStates();
      onStage_(stage);
    });
    button.label->SetInput(stageName(stage));
    button.label->GetTextProperty()->SetJustificationToCentered();
    button.label->GetTextProperty()->SetVerticalJustificationToCentered();
    button.label->GetTextProperty()->SetColor(1.0, 1.0, 1.0);
    button.label->GetTextProperty()->BoldOn();
    button.label->SetVisibility(false);
    overlay_->AddViewProp(button.label);
    buttons_.push_back(std::move(button));
  }
  states_.assign(buttons_.size(), StageState::Stale);

  auto sliderRepresentation = vtkSmartPointer<vtkSliderRepresentation2D>::New();
  sliderRepresentation->GetPoint1Coordinate()->SetCoordinateSystemToDisplay();
  sliderRepresentation->GetPoint2Coordinate()->SetCoordinateSystemToDisplay();
  sliderRepresentation->SetLabelFormat("%.3f");
  sliderRepresentation->GetSliderProperty()->SetColor(0.95, 0.75, 0.2);
  sliderRepresentation->GetTubeProperty()->SetColor(0.6, 0.6, 0.65);
  sliderRepresentation->GetCapProperty()->SetColor(0.6, 0.6, 0.65);
  sliderRepresentation->GetSelectedProperty()->SetColor(1.0, 0.9, 0.4);
  sliderRepresentation->GetTitleProperty()->ShadowOff();
  sliderRepresentation->GetLabelProperty()->ShadowOff();
  slider_ = vtkSmartPointer<vtkSliderWidget>::New();
  slider_->SetInteractor(interactor_);
  slider_->SetCurrentRenderer(overlay_);
  slider_->SetRepresentation(sliderRepresentation);
  slider_->SetAnimationModeToJump();
  observe(slider_, vtkCommand::EndInteractionEvent, [this](vtkObject*, unsigned long, void*) {
    const StageParameter* parameter = mainParameter(selected_);
    if (!parameter) return;
    auto* representation = static_cast<vtkSliderRepresentation2D*>(slider_->GetRepresentation());
    onParameter_(parameter->key, representation->GetValue());
  });
}

StageBar::~StageBar() { setEnabled(false); }

void StageBar::setEnabled(bool enabled) {
  enabled_ = enabled;
  for (auto& button : buttons_) {
    button.widget->SetEnabled(enabled);
    button.widget->GetRepresentation()->SetVisibility(enabled);  // Disabling alone leaves the face drawn.
    button.label->SetVisibility(enabled);
  }
  slider_->SetEnabled(enabled && sliderShown_);
  if (!enabled) return;
  // Enabling adds the button faces to the renderer; the labels must come after them to be drawn on top.
  for (auto& button : buttons_) {
    overlay_->RemoveViewProp(button.label);
    overlay_->AddViewProp(button.label);
  }
  applyStates();
}

void StageBar::setStates(const std::vector<StageState>& states) {
  states_ = states;
  applyStates();
}

void StageBar::applyStates() {
  for (std::size_t i = 0; i < buttons_.size(); ++i) {
    auto* representation = static_cast<vtkTexturedButtonRepresentation2D*>(buttons_[i].widget->GetRepresentation());
    const bool selected = buttons_[i].stage == selected_;
    representation->SetButtonTexture(0, buttonFace(kStaleFill, selected));
    representation->SetButtonTexture(1, buttonFace(kFreshFill, selected));
    representation->SetButtonTexture(2, buttonFace(kRunningFill, selected));
    representation->SetState(static_cast<int>(states_[i] == StageState::Stale   ? 0
                                              : states_[i] == StageState::Fresh ? 1
                                                                                : 2));
  }
}

void StageBar::setSelected(Stage stage, double parameterValue) {
  selected_ = stage;
  const StageParameter* parameter = mainParameter(stage);
  sliderShown_ = parameter != nullptr;
  auto* representation = static_cast<vtkSliderRepresentation2D*>(slider_->GetRepresentation());
  if (parameter) {
    representation->SetMinimumValue(parameter->minimum);
    representation->SetMaximumValue(parameter->maximum);
    representation->SetValue(parameterValue);
    representation->SetTitleText(parameter->key.c_str());
  }
  slider_->SetEnabled(enabled_ && sliderShown_);
  applyStates();
}

void StageBar::layout(int windowWidth, int barHeight, double scale) {
  const double margin = 6.0 * scale;
  const double buttonWidth = 96.0 * scale;
  const double buttonHeight = 28.0 * scale;
  const double y0 = (barHeight - buttonHeight) / 2.0;
  double x = margin;
  for (auto& button : buttons_) {
    double bounds[6] = {x, x + buttonWidth, y0, y0 + buttonHeight, 0.0, 0.0};
    static_cast<vtkTexturedButtonRepresentation2D*>(button.widget->GetRepresentation())->PlaceWidget(bounds);
    button.label->SetPosition(x + buttonWidth / 2.0, y0 + buttonHeight / 2.0);
    button.label->GetTextProperty()->SetFontSize(static_cast<int>(13 * scale));
    x += buttonWidth + margin;
  }
  auto* representation = static_cast<vtkSliderRepresentation2D*>(slider_->GetRepresentation());
  const double sliderStart = x + 4.0 * margin;
  const double sliderEnd = std::max(sliderStart + 80.0 * scale, windowWidth - 4.0 * margin);
  representation->GetPoint1Coordinate()->SetValue(sliderStart, barHeight * 0.66);
  representation->GetPoint2Coordinate()->SetValue(sliderEnd, barHeight * 0.66);
  // The slider's sizes are fractions of its length; keep them a fixed number of pixels.
  const double length = sliderEnd - sliderStart;
  representation->SetSliderLength(10.0 * scale / length);
  representation->SetSliderWidth(12.0 * scale / length);
  representation->SetTubeWidth(4.0 * scale / length);
  representation->SetEndCapLength(3.0 * scale / length);
  representation->SetEndCapWidth(12.0 * scale / length);
  representation->SetTitleHeight(10.0 * scale / length);
  representation->SetLabelHeight(10.0 * scale / length);
}

}  // namespace piperun::ui
