#!/usr/bin/env python3
"""doc_check.py - every public function of ghostsim.h is documented where
it is declared (STYLE.md: "Every public function documented at its
declaration").

    python3 tests/doc_check.py [ghostsim.h]

Reads the public half of the header (up to the IMPLEMENTATION banner) and
lists every GS_API declaration, and every callback typedef (gs_..._fn),
that has no comment of its own: a comment must end on the line directly
above the declaration's first line, or sit on its last line. A comment
above a run of declarations documents only the first of them, so that
each function says what it returns on failure. Exits 1 if any is
missing, printing file:line and the name of each.

It also checks that README.md's quick start is the manual's first one
(the header's QUICK START section, which tests/test_manual.c runs), line
for line but for blank lines, so that the README's copy cannot drift."""
import difflib
import os
import re
import sys

DECL = re.compile(r'^(GS_API\b|typedef\b.*\(\s*\*\s*gs_\w+_fn\s*\))')
NAME = re.compile(r'(gs_\w+)\s*\(')
FN_TYPE = re.compile(r'\(\s*\*\s*(gs_\w+_fn)\s*\)')


def public_lines(text):
    """The header's lines up to the implementation."""
    lines = text.split('\n')
    for i, line in enumerate(lines):
        if line.startswith('#ifdef GHOSTSIM_IMPLEMENTATION'):
            return lines[:i]
    return lines


def undocumented(lines):
    """(line number, name) of each declaration without its own comment."""
    missing = []
    i = 0
    while i < len(lines):
        line = lines[i]
        if not DECL.match(line):
            i += 1
            continue
        first = i
        while ';' not in lines[i] and i + 1 < len(lines):
            i += 1  # a declaration over several lines ends at its ';'
        last = i
        above = lines[first - 1].rstrip() if first > 0 else ''
        trailing = '/*' in lines[last] or '//' in lines[last]
        if not (above.endswith('*/') or trailing):
            m = FN_TYPE.search(line) or NAME.search(line)
            missing.append((first + 1, m.group(1) if m else line.strip()))
        i += 1
    return missing


def manual_quick_start(lines):
    """The code lines of the header's first QUICK START section."""
    start = next(i for i, l in enumerate(lines) if l.startswith('   QUICK START:'))
    end = next(i for i in range(start + 1, len(lines))
               if lines[i].startswith('   ') and not lines[i].startswith('    '))
    code = [l[7:] for l in lines[start + 1:end] if l.startswith('       ')]
    while code and code[0].startswith('//'):  # its note on how to build it
        code.pop(0)
    return [l.rstrip() for l in code if l.strip()]


def readme_quick_start(path):
    """The body of main() in README.md's quick start, unindented."""
    with open(path, encoding='utf-8') as f:
        text = f.read()
    a = text.index('int main(void) {\n', text.index('## Quick start'))
    b = text.index('\n}\n```', a)
    return [l[4:].rstrip() for l in text[a:b].split('\n')[1:] if l.strip()]


def main(argv):
    path = argv[1] if len(argv) > 1 else 'ghostsim.h'
    with open(path, encoding='utf-8') as f:
        lines = public_lines(f.read())
    missing = undocumented(lines)
    for number, name in missing:
        print('%s:%d: %s has no comment at its declaration' % (path, number, name))
    decls = sum(1 for line in lines if DECL.match(line))
    if missing:
        print('doc-check: %d of %d public declarations undocumented' % (len(missing), decls))
        return 1
    print('doc-check: all %d public declarations documented' % decls)
    readme = os.path.join(os.path.dirname(os.path.abspath(path)), 'README.md')
    if os.path.exists(readme):
        ours, theirs = manual_quick_start(lines), readme_quick_start(readme)
        if ours != theirs:
            for line in difflib.unified_diff(ours, theirs, 'ghostsim.h', 'README.md',
                                             lineterm=''):
                print(line)
            print('doc-check: README.md\'s quick start differs from the manual\'s')
            return 1
        print('doc-check: README.md\'s quick start is the manual\'s (%d lines)' % len(ours))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
