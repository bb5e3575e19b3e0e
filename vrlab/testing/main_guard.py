"""Is a class defined in a main script that a process started with the *spawn* method would run
again up to this very call?  (Python's ``multiprocessing`` docs, "Safe importing of main module".)"""
from __future__ import annotations

import ast
import inspect
import sys

__all__ = ["unguarded_main_script", "main_guard_advice"]


def _is_main_guard(node: ast.stmt) -> bool:
    """``if __name__ == "__main__":`` (either side)."""
    if not isinstance(node, ast.If) or not isinstance(node.test, ast.Compare) or len(node.test.ops) != 1:
        return False
    sides = [node.test.left, node.test.comparators[0]]
    return isinstance(node.test.ops[0], ast.Eq) and \
        any(isinstance(s, ast.Name) and s.id == "__name__" for s in sides) and \
        any(isinstance(s, ast.Constant) and s.value == "__main__" for s in sides)


def unguarded_main_script(cls: type) -> str | None:
    """The path of the script that defines ``cls`` if a process started with the *spawn* method
    would re-run this very call of ``check_estimator``, else None.

    A class defined in the main script pickles as ``__main__.<name>``; a spawned process finds
    it by running that script again (as ``__mp_main__``), every top-level statement outside
    ``if __name__ == "__main__":``.  If the script's statement running now (the ``<module>``
    frame of ``__main__`` on the stack) is outside such a guard, the child runs it again, starts
    processes while it is still starting itself, and dies."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if getattr(cls, "__module__", None) != "__main__" or main is None or not path:
        return None
    frame = inspect.currentframe()
    line = None
    while frame is not None:
        if frame.f_globals is main.__dict__ and frame.f_code.co_name == "<module>":
            line = frame.f_lineno
        frame = frame.f_back
    if line is None:
        return None
    try:
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
    except (OSError, SyntaxError, ValueError):
        return None
    for node in tree.body:
        if _is_main_guard(node) and node.lineno <= line <= (node.end_lineno or node.lineno):
            return None
    return path


def main_guard_advice(cls: type, path: str) -> str:
    """What to do about ``cls`` defined in the unguarded script ``path`` (one sentence for an error)."""
    return (f"{cls.__name__} is defined in the script {path}, whose top-level code is not under "
            f"'if __name__ == \"__main__\":'; a process started with the spawn method finds the class by "
            "running that script again, which runs this check_estimator call again and fails. Put the "
            "script's work (renders, check_estimator) under 'if __name__ == \"__main__\":' and keep the "
            "class definitions above it")
