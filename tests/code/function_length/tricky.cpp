// Fixture for tests/code/test_check_function_length.py: every construct here hides braces or
// looks like a function head without being one. The self-test pads `long_after_literals` so that
// it is over the limit only if the scanner counts its lines right.
#include <string>
#define OPEN_BRACE {
#define CLOSE_BRACE \
  }
#if 0
#endif

namespace fixture {
namespace {

const char* kText = "}}} { \" {";     // braces in a string
const char kOpen = '{';                // and in character literals
const char kQuote = '\'';
const int kMillion = 1'000'000;        // digit separators are not character literals
const int kThousand = 1'000;
/* a block comment { { {
   over lines } */
const char* kRaw = R"json({"a": {"b": "}"}})json";
const char* kRawLines = R"(
}
})";
const std::u8string kU8 = u8"{";
int table[] = {1, 2, 3};               // a brace initialiser, not a function
struct Point { int x{0}; int y{0}; };  // a struct, with member initialisers

}  // namespace

// A class whose body is long but whose methods are short (the class is not a function).
class Holder {
 public:
  Holder(int a, int b) : a_(a), b_{b} {  // constructor with an initialiser list
    a_ += 1;
  }
  Holder& operator=(const Holder& o) {
    a_ = o.a_;
    return *this;
  }
  int sum() const noexcept { return a_ + b_; }
  auto twice() const -> int { return 2 * sum(); }

 private:
  int a_;
  int b_;
};

extern "C" int c_entry(int v) {
  return v + 1;
}

auto namespace_lambda = [](int v) {
  return v * 2;
};

int short_with_literals() {
  std::string s = "}";  // }
  char c = '}';
  /* } */
  auto lambda = [&](int v) { return v + s.size() + c; };
  return lambda(kMillion);
}

int long_after_literals() {
  int total = 0;
  // PADDING
  return total;
}

}  // namespace fixture
