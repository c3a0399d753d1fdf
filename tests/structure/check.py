#!/usr/bin/env python3
"""The shape the source tree keeps: fails (exit 1) listing every place that breaks a rule.

Rules, over the sources of common/, proto/, server/ and client/:
  * a source file has at most 700 lines;
  * a C++ function (free, member, or defined in a class) has at most 120 lines, signature to
    closing brace;
  * a class or struct that has member functions has at most 15 data members (static members,
    types, aliases and functions do not count);
  * no #include points back up the folder order: server/ and client/ may include proto/ and
    common/, proto/ may include common/, server/ and client/ never include each other; inside
    common/ a stage includes only itself and the stages before it in the order of
    common/CMakeLists.txt's add_subdirectory lines;
and over every text file of the repository: none mentions a design document outside it.

A small brace parser, not a compiler front end: comments, string and character literals (raw
strings included) and preprocessor lines are blanked first, then braces are matched and each
opening brace is classified by the text before it (namespace, class/struct/union, enum, function,
or a block or initializer). Debian's python3-clang would parse exactly, but it is not among the
build dependencies and a full parse of every file with its includes takes minutes on the build
machine; this takes under a second.

Usage: check.py [REPO_ROOT]. Known violations of files still being reshaped are listed in
ALLOWED below, one entry per file with its reason; an entry that no longer matches is itself
reported, so the list only shrinks.
"""
import os
import re
import sys

MAX_FILE_LINES = 700
MAX_FUNCTION_LINES = 120
MAX_DATA_MEMBERS = 15
CHECKED_FOLDERS = ("common", "proto", "server", "client")
SOURCE_EXTENSIONS = (".h", ".hpp", ".cpp", ".cc", ".c", ".js", ".html", ".css", ".py")
CXX_EXTENSIONS = (".h", ".hpp", ".cpp", ".cc", ".c")

# Known violations: (rule, file, what) → why it is allowed for now. Only for files being reshaped
# elsewhere; remove the entry with the fix.
ALLOWED: dict = {}

OUTSIDE_DESIGN = re.compile(r"DESIGN\s*§|DESIGN\.md|\.\./shared|/work/shared")
KEYWORDS_NOT_FUNCTIONS = {"if", "for", "while", "switch", "catch", "do", "else", "try", "return",
                          "sizeof", "decltype", "alignof", "static_assert", "requires", "noexcept"}


def blank_code(text):
    """`text` with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#" or (line_start and c in " \t" and text[i:].lstrip(" \t").startswith("#")):
            # A preprocessor line, with its continuations.
            j = i
            while j < n:
                k = text.find("\n", j)
                if k < 0:
                    k = n
                if k > 0 and text[k - 1] == "\\":
                    j = k + 1
                    continue
                break
            out.append(re.sub(r"[^\n]", " ", text[i:k]))
            i = k
            continue
        if c == "\n":
            line_start = True
            out.append(c)
            i += 1
            continue
        if c not in " \t":
            line_start = False
        if text.startswith("//", i):
            k = text.find("\n", i)
            k = n if k < 0 else k
            out.append(" " * (k - i))
            i = k
        elif text.startswith("/*", i):
            k = text.find("*/", i + 2)
            k = n if k < 0 else k + 2
            out.append(re.sub(r"[^\n]", " ", text[i:k]))
            i = k
        elif c == "R" and i + 1 < n and text[i + 1] == '"' and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^()\\ ]{0,16})\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            k = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:k]))
            i = k
        elif c == '"' or (c == "'" and not (i > 0 and text[i - 1].isalnum())):  # 1'000'000 is a number
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            k = min(j + 1, n)
            out.append(" " * (k - i))
            i = k
        else:
            out.append(c)
            i += 1
    return "".join(out)


class Scope:
    def __init__(self, kind, name, line, head):
        self.kind = kind  # namespace, class, enum, function, block
        self.name = name
        self.line = line
        self.head = head
        self.members = 0
        self.methods = 0
        self.statement = []


def classify(head):
    """(kind, name) of the brace that follows `head`, the code since the last ; { or }."""
    h = " ".join(head.split())
    h_no_attr = re.sub(r"\[\[.*?\]\]", " ", h).strip()
    if re.match(r"^(inline\s+)?namespace\b", h_no_attr) or h_no_attr == "extern \"C\"" or re.match(r'^extern\s*$', h_no_attr):
        return "namespace", h_no_attr
    if re.search(r"^(template\s*<.*>\s*)?(class|struct|union)\b[^()=]*$", h_no_attr):
        m = re.search(r"\b(class|struct|union)\s+(?:\w+\s+)*?([A-Za-z_](?:[\w:]*\w)?)\s*(final\s*)?(:[^:{][^{]*)?$", h_no_attr)
        return "class", m.group(2) if m else "(anonymous)"
    if re.match(r"^(typedef\s+)?enum\b", h_no_attr):
        return "enum", h_no_attr
    if ")" in h_no_attr:
        # A function definition: a name and its parameter list, then qualifiers, a trailing
        # return type or a constructor's initializer list. Lambdas and control statements are
        # blocks of the function they are in.
        first = re.match(r"^\s*([A-Za-z_]\w*)", h_no_attr)
        if first and first.group(1) in KEYWORDS_NOT_FUNCTIONS:
            return "block", ""
        if re.search(r"\]\s*(\(.*\))?\s*(mutable\s*)?(constexpr\s*)?(noexcept\s*)?(->\s*[^{]*)?$", h_no_attr) and "[" in h_no_attr:
            return "block", ""  # a lambda
        if re.search(r"=\s*$|=\s*[^=]*\($", h_no_attr):
            return "block", ""
        m = re.search(r"(~?[A-Za-z_][\w:]*(?:\s*<[^()]*>)?|operator\s*[^\s(]+)\s*\(", h_no_attr)
        if m and m.group(1).split("::")[-1] not in KEYWORDS_NOT_FUNCTIONS:
            return "function", m.group(1)
    return "block", ""


def strip_angles(s):
    """`s` without template argument lists (balanced < >), so their parentheses do not count."""
    prev = None
    while prev != s:
        prev = s
        s = re.sub(r"<[^<>;{}]*>", " ", s)
    return s


def class_statement(scope, statement):
    """Counts a statement ending in ; at class scope as a data member or a member function."""
    s = " ".join(statement.split())
    s = re.sub(r"^(public|private|protected)\s*:\s*", "", s)
    s = re.sub(r"^(public|private|protected)\s*:\s*", "", s)
    if not s or re.match(r"^(using|typedef|friend|static|template|enum|class|struct|union)\b", s):
        if re.match(r"^(static|template)\b", s) and "(" in strip_angles(s).split("=")[0]:
            scope.methods += 1
        return
    if re.match(r"^(virtual\s+|explicit\s+|inline\s+|constexpr\s+|\[\[.*?\]\]\s*)*~?\w", s) is None:
        return
    bare = strip_angles(s)
    decl = re.split(r"[={]", bare, maxsplit=1)[0]
    if re.search(r"\(\s*\*\s*\w+\s*\)", decl):  # a pointer to function: a data member
        scope.members += 1
    elif "(" in decl:
        scope.methods += 1
    else:
        # One declaration may name several members: int a = 0, b = 0;
        depth = 0
        names = 1
        for ch in bare:
            if ch in "([{":
                depth += 1
            elif ch in ")]}":
                depth -= 1
            elif ch == "," and depth == 0:
                names += 1
        scope.members += names


def check_cxx(path, rel, text, problems):
    code = blank_code(text)
    stack = [Scope("namespace", "", 1, "")]
    head = []
    line = 1
    head_line = 1
    for ch in code:
        if ch == "\n":
            line += 1
        if ch == "{":
            kind, name = classify("".join(head))
            enclosing = stack[-1]
            if kind == "function" and enclosing.kind not in ("namespace", "class"):
                kind = "block"
            if kind == "function" and enclosing.kind == "class":
                enclosing.methods += 1
            scope = Scope(kind, name, head_line if kind == "function" else line, "".join(head))
            stack.append(scope)
            head = []
            head_line = line
            continue
        if ch == "}":
            if len(stack) == 1:
                problems.append(("parse", rel, "unmatched }", f"{rel}:{line}: unmatched closing brace"))
                head = []
                continue
            scope = stack.pop()
            if scope.kind == "function":
                length = line - scope.line + 1
                if length > MAX_FUNCTION_LINES:
                    problems.append(("function", rel, scope.name,
                                     f"{rel}:{scope.line}: function {scope.name} has {length} lines "
                                     f"(at most {MAX_FUNCTION_LINES})"))
            elif scope.kind == "class" and scope.methods > 0 and scope.members > MAX_DATA_MEMBERS:
                problems.append(("members", rel, scope.name,
                                 f"{rel}:{scope.line}: {scope.name} has {scope.members} data members "
                                 f"(at most {MAX_DATA_MEMBERS} in a class with member functions)"))
            # What follows a class body up to ; belongs to its declaration, not to the outer scope.
            head = [] if scope.kind != "class" else ["struct "]
            head_line = line
            continue
        if ch == ";":
            if stack[-1].kind == "class" and "".join(head).strip():
                class_statement(stack[-1], "".join(head))
            head = []
            head_line = line
            continue
        if not head and ch in " \t\n":
            head_line = line + (1 if ch == "\n" else 0)
            continue
        if not head:
            head_line = line
        head.append(ch)
    if len(stack) != 1:
        problems.append(("parse", rel, "unclosed {", f"{rel}: {len(stack) - 1} unclosed braces"))


def stage_order(root):
    order = []
    with open(os.path.join(root, "common", "CMakeLists.txt"), encoding="utf-8") as f:
        for m in re.finditer(r"^\s*add_subdirectory\(\s*(\w+)\s*\)", f.read(), re.M):
            order.append(m.group(1))
    return order


def layer(rel, stages):
    """(rank, name) of the file's folder: common's stages by their order, then proto, then the programs."""
    parts = rel.split("/")
    if parts[0] == "common":
        stage = parts[1] if len(parts) > 2 else ""
        return (stages.index(stage) if stage in stages else -1), "common/" + stage
    if parts[0] == "proto":
        return 100, "proto"
    if parts[0] in ("server", "client"):
        return 200, parts[0]
    return None


def check_includes(rel, text, stages, problems):
    mine = layer(rel, stages)
    if mine is None:
        return
    for number, line in enumerate(text.split("\n"), 1):
        m = re.match(r'\s*#\s*include\s+"([^"]+)"', line)
        if not m:
            continue
        target = layer(m.group(1), stages)
        if target is None:
            continue
        back_up = target[0] > mine[0] or (target[0] == mine[0] == 200 and target[1] != mine[1])
        if back_up:
            problems.append(("include", rel, m.group(1),
                             f"{rel}:{number}: {mine[1]} includes {m.group(1)} ({target[1]}), back up the "
                             f"folder order"))


def self_test():
    """The parser on small cases whose answer is known; raises AssertionError when it errs."""
    def cxx(text, rel="common/core/x.cpp"):
        found = []
        check_cxx(rel, rel, text, found)
        return [(rule, what) for rule, _, what, _ in found]
    body = lambda n: "\n".join("    x += %d;" % i for i in range(n - 2))
    assert cxx("int f(int x) {\n" + body(120) + "\n}\n") == []
    assert cxx("namespace a {\nint f(int x) {\n" + body(121) + "\n}\n}\n") == [("function", "f")]
    lam = "void g() {\n    auto l = [&](int y) {\n" + body(60) + "\n    };\n" + body(70) + "\n}\n"
    assert cxx(lam) == [("function", "g")], cxx(lam)
    raw = 'void h() {\n    const char* r = R"x({ "a": "}" )x";\n    char c = \'{\';\n}\nint k() { return 1; }\n'
    assert cxx(raw) == []
    fields = "".join("    int a%d = 0;\n" % i for i in range(16))
    assert cxx("struct S {\n" + fields + "    int f() const { return a0; }\n};\n") == [("members", "S")]
    assert cxx("struct P {\n" + fields + "};\n") == []  # plain data
    few = "class C {\npublic:\n    void f();\n    static int s;\n    double (*get)(int);\n" \
          "    std::function<void(int, int)> cb;\n    std::map<int, std::vector<int>> m_;\n};\n"
    assert cxx(few) == []
    assert cxx("struct T::Impl {\n" + fields + "    void f();\n};\n") == [("members", "T::Impl")]
    found = []
    check_includes("common/core/a.h", '#include "common/scene/b.h"\n#include "common/core/c.h"\n',
                   ["core", "scene"], found)
    assert [what for _, _, what, _ in found] == ["common/scene/b.h"]
    found = []
    check_includes("server/a.cpp", '#include "client/b.h"\n#include "proto/c.h"\n', ["core"], found)
    assert [what for _, _, what, _ in found] == ["client/b.h"]


def main():
    self_test()
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
    stages = stage_order(root)
    problems = []
    this_file = os.path.relpath(os.path.abspath(__file__), root)
    for dirpath, dirnames, filenames in os.walk(root):
        rel_dir = os.path.relpath(dirpath, root)
        dirnames[:] = [d for d in dirnames if not d.startswith(".") and d not in ("build", "node_modules", "out")
                       and not d.startswith("build-") and not d.startswith("build_")]
        for name in filenames:
            rel = os.path.normpath(os.path.join(rel_dir, name)).replace(os.sep, "/")
            path = os.path.join(dirpath, name)
            try:
                with open(path, encoding="utf-8") as f:
                    text = f.read()
            except (UnicodeDecodeError, OSError):
                continue  # binary files (images, EXRs, GLBs)
            if rel != this_file and OUTSIDE_DESIGN.search(text):
                for number, line in enumerate(text.split("\n"), 1):
                    if OUTSIDE_DESIGN.search(line):
                        problems.append(("design", rel, "", f"{rel}:{number}: refers to a design document "
                                                            f"outside the repository: {line.strip()[:80]}"))
            if rel.split("/")[0] not in CHECKED_FOLDERS or not name.endswith(SOURCE_EXTENSIONS):
                continue
            lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
            if lines > MAX_FILE_LINES:
                problems.append(("lines", rel, "", f"{rel}: {lines} lines (at most {MAX_FILE_LINES})"))
            if name.endswith(CXX_EXTENSIONS):
                check_cxx(path, rel, text, problems)
                check_includes(rel, text, stages, problems)
    used = set()
    failures = []
    for rule, rel, what, message in problems:
        key = (rule, rel, what)
        if key in ALLOWED:
            used.add(key)
            print(f"allowed: {message} ({ALLOWED[key]})")
        else:
            failures.append(message)
    for key in sorted(set(ALLOWED) - used):
        failures.append(f"allow-list entry {key} no longer matches: remove it")
    for message in failures:
        print(message)
    print(f"structure check: {len(failures)} problem(s), {len(used)} allowed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
