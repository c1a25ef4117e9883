// tinyobjloader's implementation, compiled here (instead of linking Debian's library)
// so that libFuzzer's coverage and the sanitizers see inside the OBJ parser.
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
