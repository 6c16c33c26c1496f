"""What `mkdocs build --strict` (scripts/test.sh) cannot see: a public name left out of
the API reference, or a header the C++ page misses. Static: needs neither mkdocs nor
the compiled module."""
import ast
import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _all_names():
    tree = ast.parse((ROOT / "python" / "vpffd" / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return ast.literal_eval(node.value)
    raise AssertionError("vpffd/__init__.py has no __all__")


def test_every_public_name_is_in_the_python_reference():
    page = (ROOT / "docs" / "reference" / "python.md").read_text()
    documented = set(re.findall(r"^::: vpffd\.(\w+)\s*$", page, re.M))
    missing = [n for n in _all_names() if n not in documented]
    assert not missing, f"add to docs/reference/python.md: {missing}"


def test_every_public_header_has_a_section_in_the_cpp_reference():
    spec = importlib.util.spec_from_file_location("gen_cpp_api", ROOT / "docs" / "gen_cpp_api.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    include = ROOT / "cpp" / "include"
    page = gen.render(include)
    for h in sorted(include.rglob("*.h")):
        assert f"### `{h.relative_to(include).as_posix()}`" in page


def test_doc_comments_become_entries():
    spec = importlib.util.spec_from_file_location("gen_cpp_api", ROOT / "docs" / "gen_cpp_api.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    file_doc, entities = gen.parse_header('''#pragma once
/// @file x.h
/// What x is.

namespace vpffd {
namespace detail {
/// hidden
inline int helper() { return 1; }
}
/// A thing.
struct Thing {
  int a = 0;  ///< the a
  /// Does it.
  /// @param n  how many
  void run(int n);
 private:
  /// not public
  int secret_;
};
enum class Mode { A, B };  // undocumented: left out
}  // namespace vpffd
''')
    assert file_doc == ["What x is."]
    assert [e.decl for e in entities if gen.documented(e)] == ["struct Thing"]
    thing = entities[0]
    assert [(c.decl, c.doc) for c in thing.children if gen.documented(c)] == [
        ("int a = 0", ["the a"]), ("void run(int n)", ["Does it.", "@param n  how many"])]
