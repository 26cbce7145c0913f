"""Python client of the AUV route planner's iceoryx2 wire.

- ``messages``: ctypes mirrors of every message, enum codes, capacities.
- ``transport``: a ``Client`` that opens the planner's services with their
  exact QoS (``inbox``, ``outbox``, ``waker``), and header stamping.
- ``validate``: the receiver-side checks the Rust processes apply.
- ``layout``: compares the mirrors with ``planner wire-layout``.

The wire contract itself is documented in the repository's ``docs/wire.md``.
"""

from . import layout, messages, transport, validate  # noqa: F401

__all__ = ["layout", "messages", "transport", "validate"]
