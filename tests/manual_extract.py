#!/usr/bin/env python3
"""manual_extract.py - the top comment's quick starts as C functions, so
that tests/test_manual.c runs exactly what the manual shows.

    python3 tests/manual_extract.py ghostsim.h OUT.h

Every section of ghostsim.h's top comment whose heading (a line of three
spaces and capitals) starts with "QUICK START" is a program: its lines
indented by seven spaces, up to the next heading, are the body of a
function. They become

    static int manual_quick_start_N(void) { ... }

(N = 1, 2... in the order of the comment), with #line directives that
point compiler messages back at ghostsim.h. Exits 1 if the comment holds
fewer than two quick starts (the simnet one and the UDP one)."""
import re
import sys

HEADING = re.compile(r'^   [A-Z][A-Z ]')
BODY = ' ' * 7


def quick_starts(lines):
    """[(heading, first line number, [body lines])] of the top comment."""
    end = next(i for i, line in enumerate(lines) if '*/' in line)
    found, current = [], None
    for i, line in enumerate(lines[:end]):
        if HEADING.match(line):
            current = None
            if line.strip().startswith('QUICK START'):
                current = (line.strip(), i + 2, [])
                found.append(current)
        elif current is not None:
            if line.strip() and not line.startswith(BODY):
                raise SystemExit('%d: a quick start line not indented by 7 spaces' % (i + 1))
            current[2].append(line[len(BODY):])
    return found


def main(argv):
    src, out = argv[1], argv[2]
    with open(src, encoding='utf-8') as f:
        lines = f.read().split('\n')
    found = quick_starts(lines)
    if len(found) < 2:
        print('manual_extract: %s has %d quick starts, not 2' % (src, len(found)))
        return 1
    text = ['/* Generated from the top comment of %s by tests/manual_extract.py:' % src,
            '   edit the comment, not this file. */']
    for n, (heading, first, body) in enumerate(found, 1):
        while body and not body[-1].strip():
            body.pop()
        text += ['', '/* %s */' % heading, 'static int manual_quick_start_%d(void) {' % n,
                 '#line %d "%s"' % (first, src)] + body + ['}']
    with open(out, 'w', encoding='utf-8') as f:
        f.write('\n'.join(text) + '\n')
    print('manual_extract: %d quick starts from %s into %s' % (len(found), src, out))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
