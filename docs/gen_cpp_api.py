"""The C++ API page, from the `///` comments of the public headers.

    python docs/gen_cpp_api.py [cpp/include] > cpp_api.md

A small reader instead of Doxygen: it walks whatever headers exist (they are split
and merged as the code grows), tracks braces to know whether a comment documents a
namespace-level or public member declaration, and writes Markdown. What it does not
understand (a comment before a blank line, private members, detail namespaces,
function bodies) it leaves out rather than guesses.
"""
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CLASS = re.compile(r"\b(class|struct|union|enum(?:\s+class|\s+struct)?)\s+(?:\[\[[^\]]*\]\]\s*)?(\w+)")
_NAMESPACE = re.compile(r"^\s*(?:inline\s+)?namespace\b\s*([\w:]*)")
_ACCESS = re.compile(r"^\s*(public|private|protected)\s*:(?!:)")
_HIDDEN_NAMESPACES = {"", "detail", "internal", "impl"}


@dataclass
class Entity:
    decl: str
    doc: list = field(default_factory=list)
    children: list = field(default_factory=list)
    kind: str = ""  # "class" for class/struct/union/enum scopes


@dataclass
class Scope:
    kind: str            # "namespace", "class", "enum", "other" (bodies, initialisers)
    visible: bool
    access: str = "public"
    entity: Entity = None


def _strip_code(line):
    """The line without string/char literals and // comments (so braces count right)."""
    line = re.sub(r'"(?:\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(?:\\.|[^'\\])*'", "''", line)
    return line.split("//", 1)[0]


def _without_template(text):
    """`template <...> struct X` -> `struct X`, nested angle brackets included."""
    while True:
        m = re.match(r"\s*template\s*<", text)
        if not m:
            return text
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"<": 1, ">": -1}.get(text[i], 0)
            i += 1
        text = text[i:]


def parse_header(text):
    """(file doc lines, top-level entities) of one header."""
    file_doc, entities = [], []
    scopes = [Scope("namespace", True)]
    doc, stmt, last_done, pending = [], "", None, None
    in_block_comment = continued_macro = False

    def visible():
        s = scopes[-1]
        return s.visible and s.kind in ("namespace", "class", "enum") and s.access == "public"

    def add(entity):
        owner = scopes[-1].entity
        (owner.children if owner is not None else entities).append(entity)

    for raw in text.splitlines():
        s = raw.strip()
        if doc and not s.startswith("///") and not file_doc and any("@file" in d for d in doc):
            file_doc, doc = [d for d in doc if "@file" not in d], []
        if continued_macro or s.startswith("#"):
            continued_macro = s.endswith("\\")
            continue
        if in_block_comment:
            in_block_comment = "*/" not in s
            continue
        if s.startswith("///<"):  # continues the trailing comment of the line above
            if last_done is not None:
                last_done.doc.append(s[4:].strip())
            continue
        if s.startswith("///"):
            doc.append(s[3:].removeprefix(" ") if s[3:4] == " " else s[3:])
            continue
        if s.startswith("/*"):
            in_block_comment = "*/" not in s
            continue
        if not s or s.startswith("//"):
            if not s:
                doc = []  # a comment followed by a blank line documents nothing
            continue
        trailing = raw.split("///<", 1)[1].strip() if "///<" in raw else None
        m = _ACCESS.match(s)
        if m:
            scopes[-1].access = m.group(1)
            s = s[m.end():]
            if not s.strip():
                continue
        code = _strip_code(raw if m is None else s)
        if not stmt.strip():
            pending = doc or None  # a comment right above documents the statement starting here
        doc = []
        done_here = None
        for ch in code:
            if ch in "{;" or (ch == "," and scopes[-1].kind == "enum") or ch == "}":
                decl = " ".join(stmt.split())
                entity = None
                if decl and ch != "}" and visible():
                    entity = Entity(decl, list(pending or []))
                pending = None
                if ch == "{":
                    head = _without_template(decl)
                    ns, cls = _NAMESPACE.match(head), _CLASS.search(head)
                    if ns or head.startswith("extern"):
                        name = ns.group(1).split("::")[-1] if ns else "extern"
                        scopes.append(Scope("namespace", scopes[-1].visible and name not in _HIDDEN_NAMESPACES))
                        entity = None
                    elif cls and "(" not in head.split(cls.group(0))[0] and "=" not in head:
                        kind = "enum" if cls.group(1).startswith("enum") else "class"
                        if entity is None and visible():
                            entity = Entity(decl)
                        if entity is not None:
                            entity.kind = "class"
                            add(entity)
                        access = "private" if cls.group(1) == "class" else "public"
                        scopes.append(Scope(kind, visible(), access, entity))
                        done_here, stmt = entity, ""
                        continue
                    else:
                        if entity is not None:
                            add(entity)
                        scopes.append(Scope("other", False))
                        done_here, stmt = entity, ""
                        continue
                elif ch == "}":
                    if len(scopes) > 1:
                        scopes.pop()
                elif entity is not None:
                    add(entity)
                done_here = entity or done_here
                stmt = ""
            else:
                stmt += ch
        stmt += " "
        if trailing is not None:
            if done_here is not None:
                done_here.doc.append(trailing)
            elif stmt.strip():
                pending = (pending or []) + [trailing]
        last_done = done_here if done_here is not None else last_done
    return file_doc, entities


def _escape(text):
    """Markdown for comment prose: backtick spans kept, the rest taken literally."""
    parts = re.split(r"(`[^`]*`)", text)
    out = []
    for p in parts:
        if p.startswith("`") and p.endswith("`") and len(p) > 1:
            out.append(p)
        else:
            p = p.replace("\\", "\\\\").replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            out.append(re.sub(r"([*_\[\]#|])", r"\\\1", p))
    return "".join(out)


def _doc_markdown(lines):
    """Doxygen-ish comment lines -> Markdown paragraphs, lists and code blocks."""
    out, para, code = [], [], None

    def flush():
        if para:
            out.append(" ".join(para))
            out.append("")
            para.clear()

    for line in lines:
        s = line.strip()
        if code is not None:
            if s.startswith("@endcode"):
                out.extend(["```cpp", *code, "```", ""])
                code = None
            else:
                code.append(line.rstrip())
            continue
        if s.startswith("@code"):
            flush()
            code = []
            continue
        m = re.match(r"@(param|tparam)(\[[a-z, ]+\])?\s+(\w+)\s*(.*)", s)
        t = re.match(r"@(throws?|exception|returns?|note|pre|post|see)\s*(.*)", s)
        if m:
            flush()
            para.append(f"- `{m.group(3)}`: {_escape(m.group(4))}")
        elif t:
            flush()
            word = {"throw": "throws", "exception": "throws", "return": "returns"}.get(t.group(1), t.group(1))
            para.append(f"- *{word}* {_escape(t.group(2))}")
        elif not s:
            flush()
        elif s.startswith(("- ", "* ")) and not para[:1] == [""]:
            flush()
            para.append("- " + _escape(s[2:].lstrip()))
        else:
            para.append(_escape(s.removeprefix("@brief ")))
    if code is not None:
        out.extend(["```cpp", *code, "```", ""])
    flush()
    return out


def documented(e):
    """Whether an entity or one of its members carries a comment."""
    return bool(e.doc) or any(documented(c) for c in e.children)


def _entity_markdown(e, depth, member=False):
    out = []
    if e.kind == "class" and any(map(documented, e.children)):
        out += [f"{'#' * depth} `{_without_template(e.decl).strip()}`", ""]
    body = _doc_markdown(e.doc)
    if member and not any(map(documented, e.children)) and len(body) <= 2 and "`" not in e.decl and len(e.decl) < 100:
        # a field or enumerator with a one-line comment: one list item, not a block
        return [f"- `{e.decl}`: {body[0] if body else ''}", ""]
    out += ["```cpp", e.decl, "```", ""] + body
    for c in e.children:
        if documented(c):
            nested = c.kind == "class" and any(map(documented, c.children))
            out += _entity_markdown(c, depth + 1 if nested else depth, True)
    return out


def render(include_dir=ROOT / "cpp" / "include"):
    """The whole page as Markdown."""
    include_dir = Path(include_dir)
    out = ["# C++ API", "",
           "Generated from the `///` comments of the public headers under `cpp/include/vpffd/` "
           "(namespace-level and public declarations). `#include \"vpffd/vpffd.h\"` brings in "
           "the header-only core; the [C++ guide](../cpp.md) shows how to build against it.", ""]
    headers = sorted(include_dir.rglob("*.h"))
    folder = None
    for h in headers:
        rel = h.relative_to(include_dir).as_posix()
        top = rel.rsplit("/", 1)[0] if rel.count("/") > 1 else "vpffd"
        if top != folder:
            folder = top
            out += [f"## `{top}/`", ""]
        file_doc, entities = parse_header(h.read_text(encoding="utf-8"))
        out += [f"### `{rel}`", ""] + _doc_markdown(file_doc)
        for e in entities:
            if documented(e):
                out += _entity_markdown(e, 4)
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.stdout.write(render(*sys.argv[1:2]))
