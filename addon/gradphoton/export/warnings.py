"""Counted export warnings: each kind reported once, with the things it concerns."""


class Warnings:
    def __init__(self):
        self._items = {}  # kind -> ordered unique subjects

    def add(self, kind, subject):
        subjects = self._items.setdefault(kind, [])
        if subject not in subjects:
            subjects.append(subject)

    def __bool__(self):
        return bool(self._items)

    def kinds(self):
        return list(self._items)

    def lines(self):
        out = []
        for kind, subjects in self._items.items():
            shown = ", ".join(subjects[:6]) + (f" and {len(subjects) - 6} more" if len(subjects) > 6 else "")
            out.append(f"{kind}: {shown}")
        return out

    def summary(self):
        """One line for Blender's report."""
        return "gradphoton approximated: " + "; ".join(self.lines()) if self._items else ""
