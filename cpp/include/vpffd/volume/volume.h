#pragma once
/// @file volume.h
/// Deprecated: a mesh's enclosed volume is a mesh property, vpffd/mesh/volume.h.
/// This header forwards there for one release.
#pragma message("vpffd/volume/volume.h is deprecated: include vpffd/mesh/volume.h")
#include "vpffd/mesh/volume.h"
