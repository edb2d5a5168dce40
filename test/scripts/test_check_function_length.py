"""scripts/check-function-length on C++ snippets whose function lengths are counted by hand.

A length is the number of lines from the body's opening brace to its closing brace, both counted;
each snippet's expected (name, line of the name, length) were read off the snippet's lines
(numbered from 1 at its first line), not from the checker. Then the program itself: its output
lines and exit status over a limit, at it and under it, and for a path that does not exist.
"""

import importlib.machinery
import importlib.util
import os
import subprocess
import tempfile
import textwrap
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts",
                      "check-function-length")


def load_checker():
    loader = importlib.machinery.SourceFileLoader("check_function_length", SCRIPT)
    spec = importlib.util.spec_from_loader(loader.name, loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


checker = load_checker()


def snippet(text):
    """The snippet without the first newline of the literal, so that line 1 is its first line."""
    return textwrap.dedent(text).lstrip("\n")


class FunctionLengths(unittest.TestCase):
    def check(self, text, expected):
        self.assertEqual(checker.function_lengths(snippet(text)), expected)

    def test_braces_in_comments_strings_and_characters_do_not_count(self):
        self.check(r'''
            // A comment with a brace {
            /* and a block comment } with
               two lines { */
            int f(int x) {
              const char* s = "}{\"{";  // a string with braces and an escaped quote
              char c = '{';
              char d = '\'';
              return x + s[0] + c + d;
            }
            ''', [("f", 4, 6)])

    def test_raw_strings_may_hold_braces_quotes_and_newlines(self):
        self.check(r'''
            const char* g() {
              return R"x(a ) " } { )" still
            inside the raw string { )x";
            }
            const char* h() { return u8R"({)"; }
            ''', [("g", 1, 4), ("h", 5, 1)])

    def test_preprocessor_lines_and_digit_separators(self):
        self.check(r'''
            #define OPEN {
            #define MULTI_LINE(x) \
              { x }
            #include <vector>
            long n() {
              return 1'000'000 + 0x1'0 + 1e-9 + 0x1p+3;
            }
            ''', [("n", 5, 3)])

    def test_namespaces_classes_and_inline_members(self):
        self.check('''
            namespace outer {
            namespace {

            class Counter : public Base {
             public:
              Counter(int n) : n_{n}, v_(n, 0), w_{} {
                reset();
              }
              int size() const { return n_; }
              bool operator()(int k) const {
                return k < n_;
              }
              Counter& operator=(const Counter& other) = default;
              virtual void pure() = 0;

             private:
              struct Inner {
                int x{3};
                void touch() { ++x; }
              } inner_;
              int n_ = 0;
              enum class Mode { A, B };
            };

            }  // namespace
            int Counter::get() const {
              return n_;
            }
            }  // namespace outer
            ''', [("Counter::Counter", 6, 3), ("Counter::size", 9, 1), ("Counter::operator()", 10, 3),
                  ("Counter::Inner::touch", 19, 1), ("Counter::get", 26, 3)])

    def test_lambdas_count_in_their_function_or_alone_at_namespace_scope(self):
        self.check('''
            auto twice = [](int x) {
              return 2 * x;
            };

            int h(std::vector<int>& v) {
              std::sort(v.begin(), v.end(), [](int a, int b) {
                return a > b;
              });
              auto k = [&] { return v.size(); };
              return static_cast<int>(k());
            }
            ''', [("twice (lambda)", 1, 3), ("h", 5, 7)])

    def test_templates_operators_macros_and_extern_c(self):
        self.check('''
            template <typename T, int N = 3>
            auto sum(const T& a) -> decltype(a + a) {
              return a + a + N;
            }
            extern "C" {
            int c_function(void) {
              return 1;
            }
            }
            TEST(Suite, Name) {
              EXPECT_EQ(1, 1);
            }
            Vec::operator bool() const noexcept { return true; }
            template <typename T>
            Foo<T>::~Foo() {
            }
            bool operator==(const Vec& a, const Vec& b) {
              return a.x == b.x;
            }
            int declared(int x);
            std::vector<int> values = {1, 2, 3};
            ''', [("sum", 2, 3), ("c_function", 6, 3), ("TEST(Suite, Name)", 10, 3),
                  ("Vec::operator bool", 13, 1), ("Foo<T>::~Foo", 15, 2), ("operator==", 17, 3)])


class Program(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="check_function_length_")
        # long_one: its braces on line 2 and, after 119 + 1 lines, on line 123: 122 lines;
        # short_one on lines 124 to 126: 3 lines.
        body = "".join(f"  x += {k};\n" for k in range(119))
        with open(os.path.join(self.folder, "long.cpp"), "w") as f:
            f.write("// header\nint long_one(int x) {\n" + body + "  return x;\n}\n"
                    "int short_one() {\n  return 0;\n}\n")

    def tearDown(self):
        for name in os.listdir(self.folder):
            os.remove(os.path.join(self.folder, name))
        os.rmdir(self.folder)

    def run_checker(self, *args):
        # In the folder: paths below the working directory are shown relative to it.
        return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True,
                              cwd=self.folder)

    def test_over_the_limit_is_reported_and_fails(self):
        result = self.run_checker("--max", "120", self.folder)
        self.assertEqual(result.returncode, 1, result.stderr)
        self.assertEqual(result.stdout, "long.cpp:2: long_one: 122 lines (more than 120)\n")

    def test_at_the_limit_passes_and_list_shows_every_function(self):
        result = self.run_checker("--max", "122", "--list", os.path.join(self.folder, "long.cpp"))
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertEqual(result.stdout, "long.cpp:2: long_one: 122 lines\nlong.cpp:124: short_one: 3 lines\n")

    def test_a_missing_path_is_an_error_naming_it(self):
        missing = os.path.join(self.folder, "missing.cpp")
        result = self.run_checker(missing)
        self.assertEqual(result.returncode, 2)
        self.assertIn(missing, result.stderr)



class ProjectSources(unittest.TestCase):
    """The project's limit (issue 13): no function in src/ longer than 120 lines."""

    def test_no_function_in_src_is_longer_than_120_lines(self):
        src = os.path.join(os.path.dirname(SCRIPT), "..", "src")
        result = subprocess.run(["/usr/bin/python3", SCRIPT, "--max", "120", src],
                                capture_output=True, text=True)
        self.assertEqual(result.returncode, 0,
                         "functions over 120 lines (split them):\n" + result.stdout + result.stderr)
        # The checker saw the sources at all: it lists a function known to be there.
        listed = subprocess.run(["/usr/bin/python3", SCRIPT, "--max", "120", "--list",
                                 os.path.join(src, "core", "simulator.cpp")],
                                capture_output=True, text=True)
        self.assertIn("Simulator::step", listed.stdout)

if __name__ == "__main__":
    unittest.main()
