// The public header compiles on its own (-Wall -Wextra -pedantic -Werror; api/CMakeLists.txt).
#include "coneshadow/coneshadow.h"
