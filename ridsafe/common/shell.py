"""The app shell: what every sans-I/O core does with MAVLink bytes, written once.

A core (sim backend, companion, GCS) is ``handle(now_s, inbound) -> outbound`` over named
endpoints; ``inbound`` and ``outbound`` are ``Datagrams``, ``(endpoint name, bytes)`` pairs.
The shell owns, per endpoint:

- the codec state of the link (one ``MavlinkLink``: parse buffer, sequence numbers, signing);
  a channel that other components of the same system also send on (the sim's autopilot and
  RID transponder share a companion's serial link) has one sending link per component;
- the sender check: which (system, component) may speak on it; the rest is refused and
  counted by reason (``ShellCounters.refused``) before the core sees it;
- the outbox: packets queued by ``send`` / ``broadcast``, joined into datagrams of at most
  ``MAX_DATAGRAM_BYTES`` (a packet is never split) by ``flush``;
- counters: datagrams in and out, datagrams for endpoints the core does not have, messages
  whose handling raised (``handler_errors``: ``dispatch`` logs the message and carries on, so
  no exception from bytes escapes a core's ``handle``), messages that could not be encoded
  (``unencodable_out``: logged and dropped), and every link's drops, with the decoded
  messages refused at the edge by ``"invalid.<MESSAGE>.<field>"`` (``codec.inbound``).

Endpoints are added by the core (fixed ones at construction; on demand through
``open_endpoint``, as the GCS opens one per companion peer) and removed when it forgets a
peer. Every check a datagram must pass before a core acts on it belongs here, so that one
change hardens every app.

    shell = AppShell("companion/3")
    shell.add(Endpoint("autopilot", MavlinkLink(3, 191), accept=from_system(3)))
    for endpoint, received in shell.receive(inbound):
        ...                                  # the core's own handling
    shell.send("autopilot", heartbeat)
    return shell.flush()
"""

from __future__ import annotations

import dataclasses
import logging
import struct
from collections.abc import Callable, Collection, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from ridsafe.common import messages as m
from ridsafe.common.codec import LinkCounters, MavlinkLink, Received, encode_payload, pack_rows
from ridsafe.common.errors import WireError

logger = logging.getLogger(__name__)

#: Datagrams stay below a typical path MTU (1500) so none is fragmented on a real network.
MAX_DATAGRAM_BYTES = 1400

Datagrams = list[tuple[str, bytes]]
#: Why a sender may not speak on an endpoint (None: it may).
SenderCheck = Callable[[Received], "str | None"]
_LINK_FIELDS = tuple(f.name for f in dataclasses.fields(LinkCounters) if f.type == "int")
#: What packing a message with a value its field cannot hold raises.
_ENCODE_ERRORS = (WireError, struct.error, ValueError, OverflowError, TypeError)


class SansIoCore(Protocol):
    """What a runner drives: the sim backend, a companion (or a fleet of them), the GCS."""

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams: ...


def join_datagrams(packets: list[bytes], max_bytes: int = MAX_DATAGRAM_BYTES) -> list[bytes]:
    """Join packets into datagrams of at most ``max_bytes`` (never splitting one; a packet
    longer than that goes alone)."""
    out: list[bytes] = []
    current = bytearray()
    for packet in packets:
        if current and len(current) + len(packet) > max_bytes:
            out.append(bytes(current))
            current = bytearray()
        current += packet
    if current:
        out.append(bytes(current))
    return out


def from_system(
    system: int, components: Collection[int] | None = None
) -> Callable[[Received], str | None]:
    """A sender check: only ``system`` (and, if given, only ``components`` of it)."""

    def check(received: Received) -> str | None:
        if received.src_system != system:
            return "foreign_system"
        if components is not None and received.src_component not in components:
            return "other_component"
        return None

    return check


def not_from_systems(systems: Collection[int]) -> Callable[[Received], str | None]:
    """A sender check: any system but ``systems`` (e.g. 0, the broadcast id, and our own)."""

    def check(received: Received) -> str | None:
        return "bad_sysid" if received.src_system in systems else None

    return check


@dataclass
class Endpoint:
    """One named endpoint of a core: its link, who may speak on it, what waits to go out."""

    name: str
    link: MavlinkLink  # parses what comes in; sends as the core's own identity
    accept: SenderCheck | None = None
    #: Other components of this system that send on the same channel, by component id.
    senders: dict[int, MavlinkLink] = field(default_factory=dict)
    outbox: list[bytes] = field(default_factory=list)
    unencodable: int = 0  # messages whose values did not fit their fields (not sent)

    def send_all(self, messages: Sequence[m.Message], component: int | None = None) -> None:
        """``send`` of each message, in order, encoded together where that is quicker (a
        batch of reports: ``MavlinkLink.pack_each``); when one does not fit, each is sent by
        ``send``, which says which."""
        link = self.link if component is None else self.senders[component]
        try:
            self.outbox.extend(link.pack_each(messages))
        except _ENCODE_ERRORS:
            for message in messages:
                self.send(message, component)

    def send(self, message: m.Message, component: int | None = None) -> None:
        """Queue ``message`` from the core's identity, or from ``component``'s. A message
        whose values do not fit its MAVLink fields is logged, counted and not sent: a value
        that crept in from outside must not take the core down (a batch of reports goes pack
        by pack, and a pack that does not fit report by report, so only the report that does
        not fit is lost)."""
        link = self.link if component is None else self.senders[component]
        if type(message) is m.ObservationRows:  # a batch of reports: pack by pack
            for pack in pack_rows(message):
                self.send(pack, component)
            return
        try:
            self.outbox.append(link.pack(message))
        except _ENCODE_ERRORS as exc:
            if type(message) is m.ObservationPack:  # its other reports still go, one by one
                for observation in message.observations:
                    self.send(observation, component)
                return
            self.unencodable += 1
            count = self.unencodable
            level = logging.WARNING if count == 1 or count % 1000 == 0 else logging.DEBUG
            logger.log(level, "%s: %r not sent (%d so far): %s", self.name, message, count, exc)


#: Stands in for a message when a sender check is asked about ids alone.
_PROBE = m.Heartbeat(0, 0, 0, 0, 0)

EndpointOpener = Callable[[str], "Endpoint | str | None"]


@dataclass
class ShellCounters:
    """What the shell took in, sent, and refused (the links count malformed bytes)."""

    datagrams_in: int = 0
    datagrams_out: int = 0
    unknown_endpoint: int = 0
    handler_errors: int = 0
    refused: dict[str, int] = field(default_factory=dict)  # by the sender check's reason

    def as_dict(self) -> dict[str, int]:
        out = {
            "datagrams_in": self.datagrams_in,
            "datagrams_out": self.datagrams_out,
            "unknown_endpoint": self.unknown_endpoint,
            "handler_errors": self.handler_errors,
        }
        out.update(self.refused)
        return out


class AppShell:
    """Link multiplexing, per-link codec state, outbox and counters of one core."""

    def __init__(self, app: str, open_endpoint: EndpointOpener | None = None) -> None:
        """``app`` names the core in log lines; ``open_endpoint(name)`` is asked for an
        endpoint the shell does not have: it returns the new endpoint, or why the datagram
        is refused (counted under that reason), or None for a name that means nothing to
        the core (counted as ``unknown_endpoint``)."""
        self.app = app
        self.endpoints: dict[str, Endpoint] = {}
        self.counters = ShellCounters()
        self._open_endpoint = open_endpoint
        self._retired = LinkCounters()
        self._retired_unencodable = 0

    def add(self, endpoint: Endpoint) -> Endpoint:
        if endpoint.name in self.endpoints:
            raise ValueError(f"{self.app}: endpoint {endpoint.name!r} exists already")
        self.endpoints[endpoint.name] = endpoint
        return endpoint

    def remove(self, name: str) -> Endpoint | None:
        """Forget an endpoint (its link's counters stay in ``link_totals``)."""
        endpoint = self.endpoints.pop(name, None)
        if endpoint is not None:
            _add_link_counters(self._retired, endpoint.link.counters)
            self._retired_unencodable += endpoint.unencodable
        return endpoint

    # -- inbound ----------------------------------------------------------------------------

    def receive(self, inbound: Iterable[tuple[str, bytes]]) -> Iterator[tuple[Endpoint, Received]]:
        """Every accepted message of ``inbound``, in order, with the endpoint it came on."""
        for name, data in inbound:
            endpoint = self.endpoints.get(name) or self._open(name)
            if endpoint is None:
                continue
            self.counters.datagrams_in += 1
            for received in endpoint.link.feed(data):
                reason = None if endpoint.accept is None else endpoint.accept(received)
                if reason is None:
                    yield endpoint, received
                else:
                    self._refuse(endpoint, received, reason)

    def valid_senders(self, name: str, data: bytes) -> set[tuple[int, int]]:
        """(system, component) pairs that sent a genuine frame in ``data`` (``MavlinkLink.
        valid_senders``) and that ``name``'s sender check admits; empty for an endpoint the
        core does not have yet. Changes nothing: the runner asks this before it lets the
        datagram's source address become the endpoint's peer."""
        endpoint = self.endpoints.get(name)
        if endpoint is None:
            return set()
        senders = set(endpoint.link.valid_senders(data))
        if endpoint.accept is None:
            return senders
        return {s for s in senders if endpoint.accept(Received(s[0], s[1], _PROBE, True)) is None}

    def dispatch(
        self,
        inbound: Iterable[tuple[str, bytes]],
        handler: Callable[[Endpoint, Received], object],
    ) -> None:
        """``handler(endpoint, received)`` for every accepted message of ``inbound``. An
        exception in the handler is logged with the message, counted in
        ``handler_errors``, and the next message is handled: one bad message never stops a
        core."""
        for endpoint, received in self.receive(inbound):
            try:
                handler(endpoint, received)
            except Exception:  # a core bug on one message must not end the process
                self.counters.handler_errors += 1
                count = self.counters.handler_errors
                level = logging.ERROR if count == 1 or count % 1000 == 0 else logging.DEBUG
                logger.log(
                    level,
                    "%s: handling %r from %d/%d on %s failed (%d so far)",
                    self.app,
                    received.message,
                    received.src_system,
                    received.src_component,
                    endpoint.name,
                    count,
                    exc_info=True,
                )

    def _open(self, name: str) -> Endpoint | None:
        opened = None if self._open_endpoint is None else self._open_endpoint(name)
        if isinstance(opened, Endpoint):
            return self.add(opened)
        if opened is None:
            self._unknown(name)
        else:
            self._count_refused(opened, f"datagram on {name!r}")
        return None

    def _unknown(self, name: str) -> None:
        self.counters.unknown_endpoint += 1
        count = self.counters.unknown_endpoint
        level = logging.WARNING if count == 1 or count % 1000 == 0 else logging.DEBUG
        logger.log(
            level, "%s: datagram on unknown endpoint %r dropped (%d so far)", self.app, name, count
        )

    def _refuse(self, endpoint: Endpoint, received: Received, reason: str) -> None:
        sender = f"{received.src_system}/{received.src_component}"
        message = received.message
        what = f"{type(message).__name__} from {sender} on {endpoint.name}"
        self._count_refused(reason, what, m.messages_in(message))

    def count_foreign(self, name: str, reason: str, count: int = 1) -> None:
        """Count ``count`` datagrams the runner dropped before the core (``common.runner``:
        not from the endpoint's locked peer or fixed remote, or lost in the kernel's full
        receive buffer) as refused for ``reason``."""
        self._count_refused(reason, f"datagram on {name!r}", count)

    def _count_refused(self, reason: str, what: str, count: int = 1) -> None:
        before = self.counters.refused.get(reason, 0)
        total = self.counters.refused[reason] = before + count
        first_or_thousand = before == 0 or total // 1000 > before // 1000
        level = logging.WARNING if first_or_thousand else logging.DEBUG
        logger.log(level, "%s: %s refused: %s (%d so far)", self.app, what, reason, total)

    # -- outbound ---------------------------------------------------------------------------

    def advance_signing_clocks(self, now_s: float) -> None:
        """Every signed link's outgoing stamps follow the core's time (``now_s`` since the
        signing clock's start): see ``MavlinkLink.advance_signing_clock``."""
        for endpoint in self.endpoints.values():
            endpoint.link.advance_signing_clock(now_s)

    def send(self, name: str, message: m.Message, component: int | None = None) -> None:
        self.endpoints[name].send(message, component)

    def send_all(
        self, name: str, messages: Sequence[m.Message], component: int | None = None
    ) -> None:
        self.endpoints[name].send_all(messages, component)

    def broadcast(self, names: Iterable[str], messages: list[m.Message]) -> None:
        """Queue ``messages`` on every endpoint of ``names``: each message is encoded once
        and framed by each endpoint's own link (its sequence numbers, its signature)."""
        if not messages:
            return
        payloads = [encode_payload(message) for message in messages]
        for name in names:
            endpoint = self.endpoints[name]
            endpoint.outbox.extend(endpoint.link.frame_all(payloads))

    def flush(self) -> Datagrams:
        """Everything queued since the last flush, as datagrams per endpoint."""
        out: Datagrams = []
        for name, endpoint in self.endpoints.items():
            if endpoint.outbox:
                out.extend((name, datagram) for datagram in join_datagrams(endpoint.outbox))
                endpoint.outbox = []
        self.counters.datagrams_out += len(out)
        return out

    # -- counters ---------------------------------------------------------------------------

    def link_counters(self) -> dict[str, LinkCounters]:
        """The counters of every endpoint's link, by endpoint."""
        return {name: endpoint.link.counters for name, endpoint in self.endpoints.items()}

    def link_totals(self) -> LinkCounters:
        """Every link's counters summed, endpoints removed since included."""
        retired = self._retired
        total = dataclasses.replace(retired, invalid_fields=dict(retired.invalid_fields))
        for endpoint in self.endpoints.values():
            _add_link_counters(total, endpoint.link.counters)
        return total

    def edge_counters(self) -> dict[str, int]:
        """What the edge refused, for ``/app/counters``: ``"invalid.<MESSAGE>.<field>"`` per
        rejected field (every link, removed ones included) and ``"unencodable_out"``."""
        total = self.link_totals()
        out = {f"invalid.{key}": count for key, count in sorted(total.invalid_fields.items())}
        out["unencodable_out"] = self._retired_unencodable + sum(
            endpoint.unencodable for endpoint in self.endpoints.values()
        )
        return out


def link_counter_values(counters: LinkCounters) -> dict[str, int]:
    """The integer counters of a link, by name."""
    return {name: int(getattr(counters, name)) for name in _LINK_FIELDS}


def _add_link_counters(total: LinkCounters, more: LinkCounters) -> None:
    for name in _LINK_FIELDS:
        setattr(total, name, getattr(total, name) + getattr(more, name))
    for key, count in more.invalid_fields.items():
        total.invalid_fields[key] = total.invalid_fields.get(key, 0) + count
