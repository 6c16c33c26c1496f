#pragma once
/// @file deformer.h
/// Deprecated: the Deformer is the frame layer, vpffd/frame/deformer.h. This header
/// forwards there for one release.
#pragma message("vpffd/ffd/deformer.h is deprecated: include vpffd/frame/deformer.h")
#include "vpffd/frame/deformer.h"
