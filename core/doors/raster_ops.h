// Operations on the door detector's rasters (row-major 0/1 images and distance lines), each exact and without
// allocation: the caller hands every buffer in.
#pragma once

#include <cstddef>
#include <cstdint>

namespace qsg::rooms::raster {

// Squared distance transform of one line (Felzenszwalb & Huttenlocher's lower envelope of parabolas): d[q] =
// min over p of (q - p)^2 + f[p]. v holds n, z n + 1 entries.
void distance_1d(const double* f, int n, double* d, std::int32_t* v, double* z);

// Zhang-Suen thinning of a 0/1 image (1: foreground), in place; the border row and column must be 0. list and
// marks hold up to cols x rows cell indices; state is a cols x rows scratch (cleared here).
void thin(std::uint8_t* m, int cols, int rows, std::uint32_t* list, std::uint32_t* marks, std::uint8_t* state);

// Zhang-Suen's removal test for a cell whose eight neighbours p2..p9 (clockwise from north, bit j = p(j+2)) are
// `neighbours`, in sub-iteration `pass` (0 or 1).
bool zhang_suen_removes(std::uint8_t neighbours, int pass);

// Binary dilation by the 3 x 3 square: out[i] = 1 where any of the cell's 3 x 3 neighbourhood (clipped to the
// image) is non-zero in `in`, else 0. `row` is a cols scratch.
void dilate3x3(const std::uint8_t* in, int cols, int rows, std::uint8_t* row, std::uint8_t* out);

}  // namespace qsg::rooms::raster
