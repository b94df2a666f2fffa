// traversal/: what the traversal kernels share -- bindings they agree on and small helpers.
#ifndef CONESHADOW_TRAVERSAL_TRAVERSE_GLSL
#define CONESHADOW_TRAVERSAL_TRAVERSE_GLSL

#include "traversal/traversal_layout.h"

uint flatIndex() {
  return CS_FLAT_INDEX(TRAVERSE_THREADS);
}

#endif
