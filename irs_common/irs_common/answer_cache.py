"""The lock-step "answer a repeated stamp with the answer already given" rule, written once.

In lock-step the rig publishes step k again when a subscriber may have missed it; every node
then publishes again exactly what it published for stamp k, with its state untouched, so the
repeat travels down the chain (docs/architecture.md, "Lock-step"). A node keeps one
:class:`AnswerCache`: ``start()`` when it begins to answer a new stamp, ``publish(pub, msg)``
for every message of that answer, ``repeat()`` when the stamp gate says REPEAT, ``clear()``
when time went back. ROS-free: ``pub`` is anything with ``publish(msg)``.
"""
from __future__ import annotations

__all__ = ['AnswerCache']


class AnswerCache:
    """The messages published for the last answered stamp, to publish again on a repeat."""

    def __init__(self) -> None:
        self._sent: list = []

    def start(self) -> None:
        """A new stamp: forget the previous answer."""
        self._sent = []

    clear = start

    def publish(self, pub, msg) -> None:
        """Publish ``msg`` on ``pub`` as a part of the current answer."""
        pub.publish(msg)
        self._sent.append((pub, msg))

    def repeat(self) -> None:
        """Publish the last answer again, in the same order (nothing if there is none)."""
        for pub, msg in self._sent:
            pub.publish(msg)

    def __len__(self) -> int:
        return len(self._sent)
