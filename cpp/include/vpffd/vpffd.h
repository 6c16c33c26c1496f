#pragma once
/// @file vpffd.h
/// Umbrella header of the header-only vpffd core.

#include "vpffd/bspline/basis.h"
#include "vpffd/bspline/knots.h"
#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"
#include "vpffd/correction/options.h"
#include "vpffd/correction/solve.h"
#include "vpffd/edits/lattice_edits.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/frame/deformer.h"
#include "vpffd/folds/certify.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/lattice.h"
#include "vpffd/mesh/shapes.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/sparse/csr.h"
#include "vpffd/sparse/spmv.h"
#include "vpffd/volume/coefficients.h"
#include "vpffd/mesh/volume.h"
