#pragma once
// Observing VTK events with a std::function (VTK 9.1 takes only vtkCommand objects or member functions).

#include <vtkCommand.h>
#include <vtkNew.h>
#include <vtkObject.h>

#include <functional>

namespace piperun::ui {

class FunctionCommand : public vtkCommand {
 public:
  static FunctionCommand* New() { return new FunctionCommand; }
  std::function<void(vtkObject* caller, unsigned long event, void* data)> function;
  void Execute(vtkObject* caller, unsigned long event, void* data) override { function(caller, event, data); }
};

/// Calls `function` on `event` of `object`; higher priorities run first. A passive observer sees
/// every event, even while a widget or the camera style holds the focus. Returns the observer tag.
inline unsigned long observe(vtkObject* object, unsigned long event,
                             std::function<void(vtkObject*, unsigned long, void*)> function, float priority = 0.0f,
                             bool passive = false) {
  vtkNew<FunctionCommand> command;
  command->function = std::move(function);
  command->SetPassiveObserver(passive);
  return object->AddObserver(event, command, priority);
}

}  // namespace piperun::ui
