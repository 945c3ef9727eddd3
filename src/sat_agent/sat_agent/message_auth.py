"""Message authentication on the swarm's topics: HMAC-SHA256 tails on serialized messages.

Any process on the ROS domain can publish anything, and the Fast DDS of the PyPI wheels has no
DDS-Security, so the application signs (SPEC.md, "Trust model"), as MAVLink 2 signing does for
drone links: every message carries HMAC-SHA256, under a per-run swarm key, over its serialized
bytes, its sender id, its step and a per-sender monotonic counter. ROS-free: bytes in, bytes out.

**Wire layout.** A signed message type ends with an ``Auth`` field (``uint64 counter``,
``uint32 sender``, ``uint32 step``, ``uint8[32] mac``: BLOCK below); a type the radio relays ends
with two, the sender's ``auth`` then the relay's seal. ``counter`` is a uint64, so CDR aligns the
block to 8 bytes from the body's start, and the block is 48 bytes long: it ends 8-aligned, so
the serializer adds no padding after it and the MAC is the last 32 bytes of the CDR payload
(tests/test_message_auth.py checks this on rclpy's serializer). That alignment matters on the
wire too: over UDP, Fast DDS pads a payload to a multiple of 4 bytes with zeros and does not
say so in the encapsulation options (measured: 78 bytes published, 80 received; over shared
memory 78), so a tail that did not end 4-aligned would not be the last bytes received.
``ros2 topic echo`` shows the fields as numbers; receivers subscribe raw and verify the exact
bytes they got (never re-serialize: padding bytes may differ between serializers).

- sign: serialize the message with a zero ``auth``, write counter, sender and step into the
  block, HMAC everything before the MAC, write the MAC (Signer.sign);
- verify: HMAC everything before the MAC, compare_digest with the MAC (MessageVerifier).

The MAC input starts with the channel, the canonical name of the topic the message is meant
for, so a signed message is refused on any other topic. **Relay**: only world_sim's radio may
write ``radio/in``; it verifies the sender's message, then seals it for one receiver: the seal's
MAC covers the inbox's channel (which names the receiver), the seal's own counter, sender and
step, and the sender's MAC (which binds the content). That costs one short HMAC per delivery
whatever the message size. A receiver checks the seal and the sender's MAC: a report of agent 2
published straight on /agent_1/radio/in/* has no seal for agent 1 and is refused.

**What it protects against.** Every swarm process holds the same key: a holder of the key (an
insider, or whoever reads the key file) can sign anything as anyone, including world messages
and relay seals. A process on the domain without the key (an outsider) cannot forge, alter,
redirect to another topic or receiver, or replay a message: it can only read traffic (nothing
is encrypted), drop or delay it, flood receivers with messages that are refused and counted,
and publish on topics that are not signed.

**Runs.** A key may serve many runs (``--key-file``: one key copied to the machines of a
swarm). Every MAC of a run is then made with that run's own key, ``run_key(key, run_id)``,
HMAC of the key over the run's id (the node parameter ``auth_run_id``; the bring-up and the
launch make a new one per run), so a recording of one run replayed into another under the same
key does not verify (``bad_signature``); otherwise the receivers' replay counters, fresh in
every run, would take what of it comes before the sender's first genuine message on a topic.
An empty id signs with the key itself (a node warns).

**Off switch.** With no key (``key is None``) a Signer leaves the tail zero and a
MessageVerifier accepts everything, counting it as ``unauthenticated``; the node must log
AUTH_OFF_WARNING. The bring-up always creates a key.
"""

from collections import Counter
from dataclasses import dataclass
import hashlib
import hmac
import os
from pathlib import Path
import stat
import struct
import time
from typing import Callable, Collection, Dict, Optional, Tuple

# The id world_sim signs with (its messages and the relay's seals); agents are 1, 2, ...
WORLD_SENDER = 0
KEY_BYTES = 32
MIN_KEY_BYTES = 32
# A key file larger than this is not a key (and is not read whole).
MAX_KEY_BYTES = 4096
MAC_BYTES = 32
# The encapsulation header of CDR (XCDR1) payloads: representation id, then options.
CDR_HEADER_BYTES = 4
_ENDIAN = {b'\x00\x00': '>', b'\x00\x01': '<'}   # CDR_BE, CDR_LE
# Separates these MACs from any other use of the key.
_DOMAIN = b'sat-swarm auth v1\x00'
# Separates a run's key (run_key) from the MACs made with the key itself.
_RUN_DOMAIN = b'sat-swarm run v1\x00'
AUTH_OFF_WARNING = ('message authentication is OFF (no auth key file given): any process on '
                    'this ROS domain can forge commands, scans, radio reports and world '
                    'messages. The bring-up creates a key for every run; pass one with '
                    '--key-file to share it across hosts.')
NO_RUN_ID_WARNING = ('no auth_run_id: this node signs with the key itself, so a recording of '
                     'another run under the same key and without an id would be taken; give '
                     'every run a new id (the bring-up and the launch do)')


def _block(order: str) -> struct.Struct:
    return struct.Struct(f'{order}QII{MAC_BYTES}s')


BLOCK_BYTES = _block('<').size   # 48


class KeyFileError(ValueError):
    """A key file that cannot be used; the message names the path and what is allowed."""


class AuthError(ValueError):
    """A message a receiver must refuse; ``reason`` names the counter it increments."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f'{reason}: {detail}')
        self.reason = reason
        self.detail = detail


@dataclass(frozen=True)
class Signed:
    """What a verified block says: who signed, for which step, with which counter."""

    sender: int
    step: int
    counter: int


@dataclass(frozen=True)
class StepWindow:
    """Steps a receiver accepts around the step it knows (learned from the world's messages).

    Peers' messages: ``known - behind <= step <= known + ahead``. World messages: ``known -
    behind <= step <= known + world_ahead`` (the world may have moved on while the receiver was
    slow); they also teach the step. Before it knows a step a receiver refuses peers' messages
    and accepts the world's first signed message whatever its step.
    """

    behind: int
    ahead: int
    world_ahead: int

    def __post_init__(self):
        for name in ('behind', 'ahead', 'world_ahead'):
            value = getattr(self, name)
            if int(value) != value or value < 0:
                raise ValueError(f'StepWindow.{name} = {value!r}: must be an integer >= 0')


# -- keys -----------------------------------------------------------------------------------

def create_key_file(path) -> Path:
    """Write a new random key to path, readable by its owner only from the first instant.

    O_EXCL refuses an existing file (or a symlink planted there), and the mode is given at
    creation: the umask can only remove bits, so the file is never readable by others.
    """
    path = Path(path)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC,
                     0o600)
    except OSError as error:
        raise KeyFileError(f'auth key file {path}: cannot create it ({error.strerror}); '
                           'it must not exist yet') from None
    with os.fdopen(fd, 'wb') as out:
        out.write(os.urandom(KEY_BYTES))
        out.flush()
        os.fsync(out.fileno())
    return path


def load_key(path) -> bytes:
    """Read a key file: a regular file of >= MIN_KEY_BYTES raw bytes, readable by its owner only.

    The owner must be this process's user or root (as OpenSSH's StrictModes): another user
    could rewrite it.
    Raises KeyFileError naming the path and the problem. The checks run on the opened file
    (fstat), so the file checked is the file read.
    """
    path = Path(path)
    try:
        # O_NONBLOCK: opening a FIFO planted at the path must not hang the node.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as error:
        raise KeyFileError(f'auth key file {path}: cannot open it ({error.strerror})') from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise KeyFileError(f'auth key file {path}: not a regular file')
    with os.fdopen(fd, 'rb') as key_file:
        if info.st_uid not in (os.geteuid(), 0):
            raise KeyFileError(
                f"auth key file {path}: owned by uid {info.st_uid}, neither this process's "
                f"user (uid {os.geteuid()}) nor root; allowed: a file of your own or root's "
                f'(chown {os.geteuid()} {path})')
        if info.st_mode & 0o077:
            raise KeyFileError(
                f'auth key file {path}: mode {stat.S_IMODE(info.st_mode):04o} lets other users '
                f'read or change it; allowed: readable by its owner only (chmod 600 {path})')
        key = key_file.read(MAX_KEY_BYTES + 1)
    if not MIN_KEY_BYTES <= len(key) <= MAX_KEY_BYTES:
        raise KeyFileError(f'auth key file {path}: {len(key)} bytes; allowed: '
                           f'{MIN_KEY_BYTES} to {MAX_KEY_BYTES} random bytes '
                           f'(head -c {KEY_BYTES} /dev/urandom)')
    return key


def run_key(key: bytes, run_id: str) -> bytes:
    """Return the key one run signs with: HMAC-SHA256 of key over run_id ('' = key itself)."""
    if not run_id:
        return key
    return hmac.new(key, _RUN_DOMAIN + run_id.encode(), hashlib.sha256).digest()


def key_from_parameter(key_file: str, run_id: str = '') -> Optional[bytes]:
    """Return run_id's key of a node's key-file parameter, or None (authentication off) for ''."""
    return run_key(load_key(key_file), run_id) if key_file else None


# -- the tail -------------------------------------------------------------------------------

def _layout(data, relayed: bool) -> Tuple[struct.Struct, int]:
    """Return (block struct in the payload's byte order, end offset of the sender's block)."""
    order = _ENDIAN.get(bytes(data[:2]))
    if order is None:
        raise AuthError('malformed', f'not a CDR payload (header {bytes(data[:4]).hex()})')
    tail = BLOCK_BYTES * (2 if relayed else 1)
    if len(data) < CDR_HEADER_BYTES + tail:
        raise AuthError('unsigned', f'{len(data)} bytes, shorter than the signature')
    if (len(data) - CDR_HEADER_BYTES) % 8:
        raise AuthError('malformed', f'{len(data)} bytes: a signed message ends 8-aligned')
    return _block(order), len(data) - (BLOCK_BYTES if relayed else 0)


def _mac(key: bytes, channel: str, *parts) -> bytes:
    digest = hmac.new(key, _DOMAIN + channel.encode() + b'\x00', hashlib.sha256)
    for part in parts:
        digest.update(part)
    return digest.digest()


def text_mac(key: bytes, channel: str, text: str, counter: int) -> str:
    """Return the hex MAC of a text sent on a standard-typed channel with its sender's counter.

    For what is not a sat_msgs type (the start-up announcements' JSON, sat_agent.ros.readiness):
    the same key, domain and channel binding as a message's block, over the counter and text.
    """
    return _mac(key, channel, int(counter).to_bytes(8, 'little'), text.encode()).hex()


def _sender_mac(key: bytes, channel: str, view: memoryview, end: int) -> bytes:
    """MAC of a sender's block ending at `end`: everything before its MAC."""
    return _mac(key, channel, view[:end - MAC_BYTES])


def _seal_mac(key: bytes, channel: str, view: memoryview) -> bytes:
    """MAC of the relay's seal (the last block): its fields and the sender's MAC before it."""
    end = len(view) - BLOCK_BYTES
    return _mac(key, channel, view[end:len(view) - MAC_BYTES], view[end - MAC_BYTES:end])


def _check_size(channel: str, data, max_bytes: Optional[int]):
    if max_bytes is not None and len(data) > max_bytes:
        raise AuthError('too_large', f'{channel}: {len(data)} bytes (at most {max_bytes})')


class MonotonicCounter:
    """Strictly increasing counter that also increases across restarts of its process.

    Starts from time.time_ns(), so a respawned sender is not taken for a replay (unless the
    wall clock went back by more than the old process's lead, e.g. after a big NTP step).
    """

    def __init__(self, clock: Callable[[], int] = time.time_ns):
        self._clock = clock
        self._last = 0

    def take(self) -> int:
        """Return the next value."""
        self._last = max(self._last + 1, int(self._clock()))
        return self._last


class Signer:
    """Signs one sender's messages (and, for world_sim, seals radio deliveries).

    ``key`` None: authentication off, messages go out with a zero tail (module docstring).
    """

    def __init__(self, key: Optional[bytes], sender: int,
                 counter: Optional[MonotonicCounter] = None):
        self.key = key
        self.sender = int(sender)
        self.counter = counter or MonotonicCounter()

    def sign(self, channel: str, data, step: int, relayed: bool = False) -> bytes:
        """Return data (serialized with a zero ``auth``) signed for channel at step.

        relayed: the type ends with a relay seal after ``auth`` (the radio's types); it stays
        zero here.
        """
        if self.key is None:
            return bytes(data)
        buffer = bytearray(data)
        block, end = _layout(buffer, relayed)
        if any(buffer[end - BLOCK_BYTES:]):
            raise ValueError(f'{channel}: serialize the message with a zero auth field to sign')
        block.pack_into(buffer, end - BLOCK_BYTES, self.counter.take(), self.sender, int(step),
                        bytes(MAC_BYTES))
        buffer[end - MAC_BYTES:end] = _sender_mac(self.key, channel, memoryview(buffer), end)
        return bytes(buffer)

    def seal(self, channel: str, data, step: int) -> bytes:
        """Return a relayed message (already verified) sealed for the inbox channel at step.

        channel names one receiver's inbox, so the seal is valid for that receiver only.
        """
        if self.key is None:
            return bytes(data)
        buffer = bytearray(data)
        block, _ = _layout(buffer, relayed=True)
        block.pack_into(buffer, len(buffer) - BLOCK_BYTES, self.counter.take(), self.sender,
                        int(step), bytes(MAC_BYTES))
        buffer[-MAC_BYTES:] = _seal_mac(self.key, channel, memoryview(buffer))
        return bytes(buffer)


class MessageVerifier:
    """A receiver's policy: refuse unsigned, badly signed, replayed and out-of-window messages.

    ``senders``: the ids allowed to sign besides WORLD_SENDER (the scenario's roster; None: any,
    for a receiver that does not know the roster and relies on the relay's check). Replays
    are judged per (signer, channel): a counter not above the last one accepted there is
    refused (``replays=False``: not judged, for a channel several processes sign as one
    sender, whose counters are not one sequence). Every refusal raises AuthError and is
    counted in ``refused`` per reason; accepted messages are counted in ``accepted`` per
    channel. ``key`` None: authentication off, every
    message is accepted (counted as ``unauthenticated``) and verify returns None. world_sim,
    which is the world, sets ``step`` itself at each step.

    Only a message its receiver takes advances the replay counter and teaches the step. A
    receiver that checks more after the signature (the content, as a decoder does) verifies with
    ``commit=False`` and calls ``commit(channel)`` once it takes the message: a signed message
    it refuses then leaves the counter where it was. Otherwise an insider's signed but invalid
    message with a counter just above a genuine one, arriving first (DDS does not order two
    writers), would have the genuine message refused as a replay.
    """

    def __init__(self, key: Optional[bytes], senders: Optional[Collection[int]],
                 window: StepWindow, replays: bool = True):
        self.key = key
        self.senders = None if senders is None else \
            frozenset(int(s) for s in senders) | {WORLD_SENDER}
        self.window = window
        self.replays = replays
        self.step: Optional[int] = None     # the step learned from the world's messages
        self.refused: Counter = Counter()   # reason -> messages refused
        self.accepted: Counter = Counter()  # channel -> messages accepted
        self._last: Dict[Tuple[int, str], int] = {}   # (signer, channel) -> last counter
        # channel -> the block of its last message verified with commit=False, not yet taken.
        self._pending: Dict[str, Signed] = {}

    @property
    def enabled(self) -> bool:
        return self.key is not None

    def verify(self, channel: str, data, relayed: bool = False, sender: Optional[int] = None,
               max_bytes: Optional[int] = None, commit: bool = True) -> Optional[Signed]:
        """Check a message received on channel; return its Signed block or raise AuthError.

        relayed: the type ends with a relay seal after the sender's block (a radio/out message,
        as the relay checks it; the seal is not looked at). sender: the only id allowed to
        sign on this channel (WORLD_SENDER for the world's topics, i for agent i's). max_bytes:
        refuse larger payloads before any hashing (also with authentication off). commit: take
        the message now (False: at commit(channel), class docstring).
        """
        try:
            signed = self._verify(channel, data, relayed, sender, max_bytes)
            self._admit(channel, signed, commit)
            return signed
        except AuthError as error:
            self.refused[error.reason] += 1
            raise

    def verify_delivery(self, channel: str, data, origin: Callable[[int], str],
                        max_bytes: Optional[int] = None, commit: bool = True) -> Optional[Signed]:
        """Check a relayed message received on the inbox channel; return the sender's block.

        The seal must be the world's, for this channel, fresh and in the step window; the
        sender's block must verify on origin(sender), the channel it was sent on (replays and
        steps of the content are the relay's and the node's business). Raises AuthError.
        commit: as for verify (the seal's counter is the one kept).
        """
        try:
            seal, signed = self._verify_delivery(channel, data, origin, max_bytes)
            self._admit(channel, seal, commit)
            return signed
        except AuthError as error:
            self.refused[error.reason] += 1
            raise

    def commit(self, channel: str):
        """Take the last message verified on channel with commit=False (class docstring)."""
        pending = self._pending.pop(channel, None)
        if pending is not None:
            self._take(channel, pending)

    def confirm(self, signed: Optional[Signed], step: int, sender: Optional[int] = None):
        """Check that the deserialized message says what its signature says, or raise AuthError.

        step: the message's step field; sender: its sender id field, where it names one.
        """
        if signed is None:
            return
        if signed.step != step or (sender is not None and signed.sender != sender):
            self.refused['mismatch'] += 1
            raise AuthError('mismatch', f'signed by {signed.sender} for step {signed.step}, '
                                        f'the message says {sender} and step {step}')

    def check_window(self, channel: str, sender: int, step: int):
        """Hold an unsigned message's own sender and step to the step window, or raise AuthError.

        For receivers that keep what they accept (the observers): with authentication off the
        message's fields are all there is, and a step far ahead must not be kept forever. A
        world message (sender WORLD_SENDER) teaches the step as a signed one would.
        """
        signed = Signed(int(sender), int(step), 0)
        try:
            self._check_step(channel, signed)
        except AuthError as error:
            self.refused[error.reason] += 1
            raise
        self._learn_step(signed)

    def _verify(self, channel: str, data, relayed: bool, sender: Optional[int],
                max_bytes: Optional[int]) -> Optional[Signed]:
        _check_size(channel, data, max_bytes)
        if self.key is None:
            return None
        block, end = _layout(data, relayed)
        return self._check(block, data, end, lambda _: channel, seal=False, expected=sender)

    def _verify_delivery(self, channel, data, origin, max_bytes):
        _check_size(channel, data, max_bytes)
        if self.key is None:
            return None, None
        block, end = _layout(data, relayed=True)
        seal = self._check(block, data, len(data), lambda _: channel, seal=True,
                           expected=WORLD_SENDER)
        return seal, self._check(block, data, end, origin, seal=False)

    def _check(self, block: struct.Struct, data, end: int, channel_of: Callable[[int], str],
               seal: bool, expected: Optional[int] = None) -> Signed:
        """Verify the block ending at `end` (a seal: the last one); return what it says.

        expected: the only signer allowed (a seal's is the radio's, WORLD_SENDER).
        """
        counter, sender, step, mac = block.unpack_from(data, end - BLOCK_BYTES)
        what = 'seal' if seal else 'signature'
        if not any(mac):
            raise AuthError('unsigned', f'{channel_of(sender)}: no {what}')
        if self.senders is not None and sender not in self.senders:
            raise AuthError('unknown_sender',
                            f'{channel_of(sender)}: signed by {sender}, not on the roster')
        if expected is not None and sender != expected:
            raise AuthError('not_relayed' if seal else 'wrong_sender',
                            f'{channel_of(sender)}: {what} of {sender}, only {expected} may')
        view = memoryview(data)
        channel = channel_of(sender)
        expected_mac = _seal_mac(self.key, channel, view) if seal else \
            _sender_mac(self.key, channel, view, end)
        if not hmac.compare_digest(mac, expected_mac):
            raise AuthError('bad_signature', f'{channel}: the {what} of {sender} does not verify')
        return Signed(sender, step, counter)

    def _admit(self, channel: str, signed: Optional[Signed], commit: bool):
        """Refuse a replay or a step out of the window; take the message or keep it pending."""
        if signed is None:
            self.accepted['unauthenticated'] += 1
            return
        last = self._last.get((signed.sender, channel))
        if self.replays and last is not None and signed.counter <= last:
            raise AuthError('replayed', f'{channel}: counter {signed.counter} of {signed.sender} '
                                        f'not above {last}')
        self._check_step(channel, signed)
        if commit:
            self._take(channel, signed)
        else:
            self._pending[channel] = signed

    def _take(self, channel: str, signed: Signed):
        self._last[(signed.sender, channel)] = signed.counter
        self._learn_step(signed)
        self.accepted[channel] += 1

    def _learn_step(self, signed: Signed):
        if signed.sender == WORLD_SENDER:
            self.step = signed.step if self.step is None else max(self.step, signed.step)

    def _check_step(self, channel: str, signed: Signed):
        world = signed.sender == WORLD_SENDER
        if self.step is None:
            if world:
                return
            raise AuthError('step_unknown', f'{channel}: step {signed.step} of {signed.sender} '
                                            'before any world message')
        ahead = self.window.world_ahead if world else self.window.ahead
        if not self.step - self.window.behind <= signed.step <= self.step + ahead:
            raise AuthError('out_of_window', f'{channel}: step {signed.step} of {signed.sender} '
                                             f'at step {self.step}')
