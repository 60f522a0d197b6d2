#pragma once
// Scene files (JSON) to plain data (io/SceneDesc.h). Every field is checked; an error names the file, the
// JSON path and what is allowed, and unknown keys are errors. The keys themselves are declared once, where
// they belong (io/SceneKeys.h, materials/, core/shapes/), and docs/scene-format.md is generated from them.
#include <string>
#include <string_view>

#include "io/SceneDesc.h"

namespace mpm {

/// Reads and checks a scene file. Throws SceneError.
SceneDesc loadScene(const std::string& path);
/// The same for scene text in memory; `path` names it in errors and gives the scene its name.
SceneDesc parseScene(const std::string& text, const std::string& path);

/// Every field with its default and allowed values, as Markdown (`mpm validate --explain`).
std::string explainSceneFormat();
/// The complete scene docs/scene-format.md shows first (a test runs it): a dam of water behind a gate lifted by
/// keyframes, in a tank, and a jelly ball thrown in later.
std::string_view exampleScene();

}  // namespace mpm
