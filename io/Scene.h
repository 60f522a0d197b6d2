#pragma once
// Scenes: the plain description (SceneDesc.h), the JSON reader (SceneReader.h) and the builder of a
// Simulation (SceneBuilder.h).
#include "io/SceneBuilder.h"
#include "io/SceneDesc.h"
#include "io/SceneReader.h"
