#pragma once
/// @file csr.h
/// Compressed sparse row matrix with 64-bit row pointers (the paper's matrix for
/// a 10M-face mesh has more than 2^31 entries) and 32-bit column indices.

#include <cstdint>
#include <vector>

#include "vpffd/core/types.h"

namespace vpffd {

struct CsrMatrix {
  Index rows = 0, cols = 0;
  std::vector<std::int64_t> indptr;   ///< rows + 1
  std::vector<std::int32_t> indices;  ///< nnz column indices, increasing within a row
  std::vector<double> values;         ///< nnz values
  Index nnz() const { return static_cast<Index>(values.size()); }
  size_t bytes() const {
    return indptr.size() * sizeof(std::int64_t) + indices.size() * sizeof(std::int32_t) +
           values.size() * sizeof(double);
  }
};

}  // namespace vpffd
