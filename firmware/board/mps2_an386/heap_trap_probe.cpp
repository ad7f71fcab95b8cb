// Allocates on purpose: linking this image must fail with the heap trap's symbol.
#include <cstdlib>

int main() {
  void* volatile p = std::malloc(16);
  return p != nullptr ? 0 : 1;
}
