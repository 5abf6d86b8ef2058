"""The MAVLink mission protocol of one simulated autopilot, sans I/O, as ArduCopter answers it.

``MissionStore`` holds the three lists (mission, fence, rally). As on ArduPilot, mission item
0 is home (a NAV_WAYPOINT at the home position, filled in on download); uploads overwrite the
list from item 0, and the item stored as 0 is replaced by home.

``MissionTransfer`` is one link's transfer state:

- download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT (or the float
  MISSION_REQUEST) n -> MISSION_ITEM_INT (MISSION_ITEM); the client ends with MISSION_ACK;
- upload: MISSION_COUNT n -> MISSION_REQUEST_INT 0, each item -> the next request, the last
  -> MISSION_ACK ACCEPTED; an item out of sequence is answered by asking again for the one
  expected; MISSION_CLEAR_ALL -> MISSION_ACK;
- guided waypoints: MISSION_ITEM_INT / MISSION_ITEM with ``current`` 2 is not stored: the
  vehicle flies there in GUIDED (``GuidedTarget``) and the answer is MISSION_ACK.

The handler returns the messages to send back on the link; a guided target it returns for
the autopilot to apply.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ridsafe.common import protocol_messages as pm
from ridsafe.common.protocol_messages import MissionResult, MissionType

MAX_ITEMS = 700  # ArduCopter's mission storage on SITL holds more; plenty for tests
NAV_WAYPOINT = 16
NAV_RETURN_TO_LAUNCH = 20
NAV_LAND = 21
NAV_TAKEOFF = 22
_LISTS = frozenset({MissionType.MISSION, MissionType.FENCE, MissionType.RALLY})
GUIDED_CURRENT = 2  # MISSION_ITEM.current: a guided-mode target, not a stored item
MissionItemAny = pm.MissionItemInt | pm.MissionItem


@dataclass(frozen=True)
class StoredItem:
    """One stored item; ``params[4:7]`` lat/lon (deg) and altitude (m) for global frames."""

    frame: int
    command: int
    autocontinue: int
    params: pm.Params7


@dataclass(frozen=True)
class GuidedTarget:
    frame: int
    lat_deg: float
    lon_deg: float
    alt_m: float


@dataclass
class MissionStore:
    lists: dict[MissionType, list[StoredItem]] = field(
        default_factory=lambda: {
            t: [] for t in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY)
        }
    )
    current_seq: int = 0

    def count(self, mission_type: int) -> int:
        """Items a download reports; the mission list always has home as item 0."""
        items = self.lists.get(MissionType(mission_type), [])
        return max(len(items), 1) if mission_type == MissionType.MISSION else len(items)

    def item(self, mission_type: int, seq: int, home: tuple[float, float, float]) -> StoredItem:
        if mission_type == MissionType.MISSION and seq == 0:
            return StoredItem(0, NAV_WAYPOINT, 1, (0.0, 0.0, 0.0, 0.0, *home))
        return self.lists[MissionType(mission_type)][seq]

    def nav_items(self) -> list[StoredItem]:
        """The mission after home, as AUTO flies it."""
        return self.lists[MissionType.MISSION][1:]


@dataclass
class _Upload:
    mission_type: MissionType
    count: int
    items: list[StoredItem] = field(default_factory=list)


@dataclass
class MissionTransfer:
    """One link's mission transfers for the vehicle ``sysid`` (answers address the client)."""

    sysid: int
    upload: _Upload | None = None

    def handle(
        self,
        msg: pm.ProtocolMessage,
        store: MissionStore,
        home: tuple[float, float, float],
        client: tuple[int, int],
    ) -> tuple[list[pm.ProtocolMessage], GuidedTarget | None]:
        """Answer one mission-protocol message from ``client`` (sysid, compid)."""
        if isinstance(msg, pm.MissionItemInt | pm.MissionItem) and msg.current == GUIDED_CURRENT:
            return [], GuidedTarget(msg.frame, msg.params[4], msg.params[5], msg.params[6])
        if isinstance(msg, pm.MissionRequestList):
            return [self._count(store, msg.mission_type, client)], None
        if isinstance(msg, pm.MissionRequestInt | pm.MissionRequest):
            return [self._item(msg, store, home, client)], None
        if isinstance(msg, pm.MissionCount):
            return self._start_upload(msg, client), None
        if isinstance(msg, pm.MissionItemInt | pm.MissionItem):
            return self._upload_item(msg, store, client), None
        return self._other(msg, store, client), None

    def _other(
        self, msg: pm.ProtocolMessage, store: MissionStore, client: tuple[int, int]
    ) -> list[pm.ProtocolMessage]:
        if isinstance(msg, pm.MissionClearAll):
            return self._clear(msg.mission_type, store, client)
        if isinstance(msg, pm.MissionSetCurrent):
            return self._set_current(msg.seq, store)
        return []  # MISSION_ACK of a download: nothing to do

    def _count(
        self, store: MissionStore, mission_type: int, client: tuple[int, int]
    ) -> pm.ProtocolMessage:
        if mission_type not in _LISTS:
            return pm.MissionAck(*client, MissionResult.UNSUPPORTED, mission_type)
        return pm.MissionCount(*client, store.count(mission_type), mission_type)

    def _item(
        self,
        msg: pm.MissionRequestInt | pm.MissionRequest,
        store: MissionStore,
        home: tuple[float, float, float],
        client: tuple[int, int],
    ) -> pm.ProtocolMessage:
        if msg.mission_type not in _LISTS or not 0 <= msg.seq < store.count(msg.mission_type):
            return pm.MissionAck(*client, MissionResult.INVALID_SEQUENCE, msg.mission_type)
        item = store.item(msg.mission_type, msg.seq, home)
        cls = pm.MissionItemInt if isinstance(msg, pm.MissionRequestInt) else pm.MissionItem
        current = int(msg.mission_type == MissionType.MISSION and msg.seq == store.current_seq)
        return cls(*client, msg.seq, item.frame, item.command, current, item.autocontinue,
                   item.params, msg.mission_type)  # fmt: skip

    def _start_upload(
        self, msg: pm.MissionCount, client: tuple[int, int]
    ) -> list[pm.ProtocolMessage]:
        if msg.mission_type not in _LISTS:
            return [pm.MissionAck(*client, MissionResult.UNSUPPORTED, msg.mission_type)]
        if msg.count > MAX_ITEMS:
            return [pm.MissionAck(*client, MissionResult.NO_SPACE, msg.mission_type)]
        kind = MissionType(msg.mission_type)
        self.upload = _Upload(kind, msg.count)
        if msg.count == 0:
            self.upload = None
            return [pm.MissionAck(*client, MissionResult.ACCEPTED, msg.mission_type)]
        return [pm.MissionRequestInt(*client, 0, msg.mission_type)]

    def _upload_item(
        self, msg: MissionItemAny, store: MissionStore, client: tuple[int, int]
    ) -> list[pm.ProtocolMessage]:
        upload = self.upload
        if upload is None or msg.mission_type != upload.mission_type:
            return [pm.MissionAck(*client, MissionResult.DENIED, msg.mission_type)]
        expected = len(upload.items)
        if msg.seq != expected:
            return [pm.MissionRequestInt(*client, expected, msg.mission_type)]
        upload.items.append(StoredItem(msg.frame, msg.command, msg.autocontinue, msg.params))
        if len(upload.items) < upload.count:
            return [pm.MissionRequestInt(*client, expected + 1, msg.mission_type)]
        store.lists[upload.mission_type] = upload.items
        if upload.mission_type == MissionType.MISSION:
            store.current_seq = 1 if len(upload.items) > 1 else 0
        self.upload = None
        return [pm.MissionAck(*client, MissionResult.ACCEPTED, msg.mission_type)]

    def _clear(
        self, mission_type: int, store: MissionStore, client: tuple[int, int]
    ) -> list[pm.ProtocolMessage]:
        types = list(store.lists) if mission_type == MissionType.ALL else [mission_type]
        for kind in types:
            if kind in store.lists:
                store.lists[MissionType(kind)] = []
        store.current_seq = 0
        return [pm.MissionAck(*client, MissionResult.ACCEPTED, mission_type)]

    def _set_current(self, seq: int, store: MissionStore) -> list[pm.ProtocolMessage]:
        if 0 <= seq < store.count(MissionType.MISSION):
            store.current_seq = seq
        return [pm.MissionCurrent(store.current_seq, store.count(MissionType.MISSION))]


MISSION_MESSAGES = (
    pm.MissionRequestList,
    pm.MissionRequestInt,
    pm.MissionRequest,
    pm.MissionCount,
    pm.MissionItemInt,
    pm.MissionItem,
    pm.MissionClearAll,
    pm.MissionSetCurrent,
    pm.MissionAck,
)
