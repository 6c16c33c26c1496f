#pragma once
/// @file progress.h
/// The progress callback of long precomputations (the multiresolution decompositions).

#include <functional>

namespace vpffd {

/// Called after each stage of a long precomputation, on the calling thread, between
/// parallel regions: the stage's name, the stages done and their total, and a figure
/// of the stage (the RMS displacement after it). May be empty; what it throws stops
/// the work and propagates.
using StageProgress = std::function<void(const char* stage, int done, int total, double value)>;

}  // namespace vpffd
