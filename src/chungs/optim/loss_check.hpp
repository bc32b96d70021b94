// Shape checks shared by the losses.
#pragma once
#include "chungs/common/error.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

template <typename A, typename B>
void require_same_shape(const Image<A>& a, const Image<B>& b, const char* what) {
  if (a.width() != b.width() || a.height() != b.height() || a.channels() != b.channels())
    fail(what, " is ", b.width(), "x", b.height(), "x", b.channels(), ", expected ", a.width(), "x",
         a.height(), "x", a.channels());
}

}  // namespace chungs
