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
#include <vtkStdString.h>
#include <vtkTextProperty.h>
#include <vtkTextRenderer.h>
#include <vtkTexturedButtonRepresentation2D.h>

#include <algorithm>
#include <array>

namespace piperun::ui {

namespace {

const std::array<StageParameter, 6> kMainParameters{{{"preprocess.voxel_size", 0.003, 0.05},
                                                     {"directions.bandwidth_deg", 0.5, 10.0},
                                                     {"placement.center_bandwidth", 0.002, 0.05},
                                                     {"extents.section_length", 0.01, 0.2},
                                                     {"merge.max_gap", 0.0, 0.5},
                                                     {"joints.accept_confidence", 0.0, 1.0}}};

/// A flat button face of width × height pixels with a darker border (a light one when `selected`)
/// and the stage's name drawn in the middle.
vtkSmartPointer<vtkImageData> buttonFace(const char* label, Rgb fill, bool selected, int width, int height,
                                         double scale) {
  const int border = std::max(2, static_cast<int>(2 * scale));
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(width, height, 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      auto* pixel = static_cast<unsigned char*>(image->GetScalarPointer(x, y, 0));
      const bool edge = x < border || y < border || x >= width - border || y >= height - border;
      for (int c = 0; c < 3; ++c) pixel[c] = !edge ? fill[c] : selected ? 255 : static_cast<unsigned char>(fill[c] / 2);
    }

  vtkNew<vtkTextProperty> font;
  font->SetFontFamilyToArial();
  font->SetFontSize(static_cast<int>(std::min(13.0 * scale, width / 7.5)));
  font->BoldOn();
  font->SetColor(1.0, 1.0, 1.0);
  vtkNew<vtkImageData> text;
  int textSize[2] = {0, 0};
  if (!vtkTextRenderer::GetInstance()->RenderString(font.Get(), vtkStdString(label), text.Get(), textSize, 72))
    return image;
  // Alpha-blend the white text (RGBA) centred on the face.
  const int x0 = (width - textSize[0]) / 2, y0 = (height - textSize[1]) / 2;
  int textExtent[6];
  text->GetExtent(textExtent);
  for (int y = 0; y < textSize[1]; ++y)
    for (int x = 0; x < textSize[0]; ++x) {
      const int fx = x0 + x, fy = y0 + y;
      if (fx < 0 || fy < 0 || fx >= width || fy >= height) continue;
      const auto* source = static_cast<unsigned char*>(text->GetScalarPointer(textExtent[0] + x, textExtent[2] + y, 0));
      auto* target = static_cast<unsigned char*>(image->GetScalarPointer(fx, fy, 0));
      const double alpha = source[3] / 255.0;
      for (int c = 0; c < 3; ++c) target[c] = static_cast<unsigned char>(alpha * source[c] + (1.0 - alpha) * target[c]);
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
    Button button{stage, vtkSmartPointer<vtkButtonWidget>::New()};
    auto representation = vtkSmartPointer<vtkTexturedButtonRepresentation2D>::New();
    representation->SetNumberOfStates(3);
    representation->SetPlaceFactor(1.0);  // The default 0.5 would shrink the button inside its bounds.
    button.widget->KeyPressActivationOff();  // no "i" key toggling it: the bar is always shown
    button.widget->SetInteractor(interactor_);
    button.widget->SetCurrentRenderer(overlay_);
    button.widget->SetRepresentation(representation);
    // A click advances the button's own state; the bar shows the pipeline's instead.
    observe(button.widget, vtkCommand::StateChangedEvent, [this, stage](vtkObject*, unsigned long, void*) {
      applyStates();
      onStage_(stage);
    });
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
  slider_->KeyPressActivationOff();
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
  }
  slider_->SetEnabled(enabled && sliderShown_);
  if (enabled) applyStates();
}

void StageBar::setStates(const std::vector<StageState>& states) {
  states_ = states;
  applyStates();
}

void StageBar::applyStates() {
  for (std::size_t i = 0; i < buttons_.size(); ++i) {
    auto* representation = static_cast<vtkTexturedButtonRepresentation2D*>(buttons_[i].widget->GetRepresentation());
    const bool selected = buttons_[i].stage == selected_;
    const char* label = stageName(buttons_[i].stage);
    representation->SetButtonTexture(0, buttonFace(label, kStaleFill, selected, faceWidth_, faceHeight_, scale_));
    representation->SetButtonTexture(1, buttonFace(label, kFreshFill, selected, faceWidth_, faceHeight_, scale_));
    representation->SetButtonTexture(2, buttonFace(label, kRunningFill, selected, faceWidth_, faceHeight_, scale_));
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
  // Buttons take at most 55 % of the width, so the slider keeps room in narrow windows.
  const double count = static_cast<double>(buttons_.size());
  const double buttonWidth = std::min(96.0 * scale, (0.55 * windowWidth - margin * (count + 1)) / count);
  const double buttonHeight = 28.0 * scale;
  const double y0 = (barHeight - buttonHeight) / 2.0;
  double x = margin;
  for (auto& button : buttons_) {
    double bounds[6] = {x, x + buttonWidth, y0, y0 + buttonHeight, 0.0, 0.0};
    static_cast<vtkTexturedButtonRepresentation2D*>(button.widget->GetRepresentation())->PlaceWidget(bounds);
    x += buttonWidth + margin;
  }
  auto* representation = static_cast<vtkSliderRepresentation2D*>(slider_->GetRepresentation());
  const double sliderStart = x + 4.0 * margin;
  const double sliderEnd = std::max(sliderStart + 80.0 * scale, windowWidth - 4.0 * margin);
  const bool resized = faceWidth_ != static_cast<int>(buttonWidth) || faceHeight_ != static_cast<int>(buttonHeight);
  faceWidth_ = static_cast<int>(buttonWidth);
  faceHeight_ = static_cast<int>(buttonHeight);
  scale_ = scale;
  if (resized) applyStates();
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
