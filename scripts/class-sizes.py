#!/usr/bin/python3
"""Method declarations and synchronisation members of each class in the given headers.

  scripts/class-sizes.py server           # every header under server/, largest class first

A method is a declaration in the class body (nested types' bodies and inline function bodies
skipped) with a name followed by a parameter list: constructors, the destructor, deleted
copies and operators included. A synchronisation member is a data member whose type is a
mutex, a condition variable, an atomic, a thread or a BoundedQueue.
"""
import pathlib
import re
import sys

SYNC = re.compile(r'\b(std::(mutex|shared_mutex|recursive_mutex|condition_variable|atomic|thread|'
                  r'jthread)|FifoMutex|BoundedQueue)\b')


def strip_comments(text):
    text = re.sub(r'/\*.*?\*/', '', text, flags=re.S)
    return re.sub(r'//[^\n]*', '', text)


def collapse(body):
    """The body with every brace-enclosed part at depth >= 1 replaced by {}."""
    out, depth = [], 0
    for ch in body:
        if ch == '{':
            if depth == 0:
                out.append('{}')
            depth += 1
        elif ch == '}':
            depth -= 1
        elif depth == 0:
            out.append(ch)
    return ''.join(out)


def without_templates(s):
    prev = None
    while prev != s:
        prev = s
        s = re.sub(r'<[^<>]*>', '', s)
    return s


def classes(text):
    text = strip_comments(text)
    for m in re.finditer(r'\bclass\s+(\w+)[^;{]*\{', text):
        depth, i = 1, m.end()
        while depth and i < len(text):
            depth += {'{': 1, '}': -1}.get(text[i], 0)
            i += 1
        yield m.group(1), collapse(text[m.end():i - 1])


def count(body):
    methods = sync = 0
    for seg in re.split(r';|\{\}', body):
        seg = re.sub(r'\b(public|private|protected)\s*:', '', seg).strip()
        if not seg:
            continue
        plain = without_templates(seg)
        if re.search(r'(~?\b\w+|operator\s*\S+)\s*\(', plain) and not re.match(r'(class|struct|enum|using)\b', plain):
            if '=' in plain.split('(')[0] or re.search(r'\w\s*\{', plain.split('(')[0]):
                pass  # a data member initialised by a call
            else:
                methods += 1
                continue
        if SYNC.search(seg):
            sync += 1
    return methods, sync


def main():
    rows = []
    for root in sys.argv[1:] or ['server']:
        for path in sorted(pathlib.Path(root).rglob('*.h')):
            for name, body in classes(path.read_text()):
                rows.append((*count(body), name, str(path)))
    for methods, sync, name, path in sorted(rows, reverse=True):
        print(f'{methods:4d} methods {sync:3d} sync  {name:28s} {path}')


if __name__ == '__main__':
    main()
