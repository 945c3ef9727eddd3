"""Signed topics on the ROS side: the key parameter, signing publishers, verified subscriptions.

The maths is sat_agent.message_auth (ROS-free); this module moves bytes between it and rclpy:

- ``auth_key(node, params)``: the key of the node parameter ``auth_key_file`` (a path, never the
  key itself: parameters are readable through services, command lines through /proc;
  sat_agent.node_params), made the run's own by ``auth_run_id`` (message_auth.run_key).
  '' = authentication off, logged at WARN (message_auth.AUTH_OFF_WARNING) and shown on
  /diagnostics.
- ``SignedPublisher``: serializes a message with a zero ``auth`` and publishes the signed bytes.
  Every signed publish goes through Signer.sign, which refuses payloads shorter than the
  signature: an empty DDS sample stalls every later sample of its reliable writer.
- ``VerifiedInput.subscribe``: a raw subscription whose callback, in this order, checks the
  payload's size (message_limits, also with authentication off), verifies the signature (or a
  relayed message's seal), deserializes in a try, checks that the fields say what the
  signature says (sender, step) and only then calls the node's callback with the message. A
  message refused on the way is counted per reason by the node's InputGuard (/diagnostics)
  and never deserialized when its size or signature is wrong. Only a message taken advances
  its sender's replay counter (MessageVerifier.commit): one refused after its signature
  verified (undecodable, bad content, fields that disagree) leaves it where it was.
"""

from typing import Callable, Collection, Optional

from rclpy.serialization import deserialize_message, serialize_message

from sat_agent.message_auth import (AUTH_OFF_WARNING, AuthError, key_from_parameter,
                                    MessageVerifier, NO_RUN_ID_WARNING, Signed, Signer,
                                    StepWindow, WORLD_SENDER)
from sat_agent.ros.msg_conversions import InvalidMessage


def auth_key(node, params) -> Optional[bytes]:
    """Return the run's key of params' ``auth_key_file`` and ``auth_run_id`` (None: auth off).

    params: the node's node_params.InputParams. Authentication off and a key without a run id
    are warned at WARN, a run id logged at INFO.

    A key file that cannot be used raises message_auth.KeyFileError (a ValueError naming the
    path): node_runner prints it as one line and the process exits with code 2.
    """
    key = key_from_parameter(params.auth_key_file, params.auth_run_id)
    if key is None:
        node.get_logger().warning(AUTH_OFF_WARNING)
    elif params.auth_run_id:
        # A node given another run's id refuses all the run's messages as bad_signature.
        node.get_logger().info(f'signing and verifying for run {params.auth_run_id!r}')
    else:
        node.get_logger().warning(NO_RUN_ID_WARNING)
    return key


class SignedPublisher:
    """A publisher of one signed sat_msgs type: publish(msg, step) signs as its node's sender.

    relayed: the type ends with a relay seal after ``auth`` (the radio's types).
    """

    def __init__(self, node, msg_type, topic: str, qos, signer: Signer, relayed: bool = False):
        self.publisher = node.create_publisher(msg_type, topic, qos)
        self.channel = self.publisher.topic_name
        self.signer = signer
        self.relayed = relayed

    def publish(self, msg, step: int):
        """Serialize msg (its auth fields zero), sign it for step and publish the bytes."""
        self.publisher.publish(self.signer.sign(self.channel, serialize_message(msg), step,
                                                self.relayed))

    def __getattr__(self, name):
        # The rest is the publisher's (topic_name, get_subscription_count, wait_for_all_acked).
        return getattr(self.publisher, name)


class VerifiedInput:
    """One node's verifier of signed input; raw subscriptions that refuse before deserializing.

    senders: the roster (agent ids) besides the world; window: message_auth.StepWindow.
    window_without_key: also apply the step window to the messages' own step fields when
    authentication is off (the observers: their step window is their only bound on what they
    keep; agents and world_sim have their own step checks). replays: MessageVerifier's.
    """

    def __init__(self, node, guard, key: Optional[bytes], senders: Optional[Collection[int]],
                 window: StepWindow, window_without_key: bool = False, replays: bool = True):
        self.node = node
        self.guard = guard
        self.verifier = MessageVerifier(key, senders, window, replays)
        self.window_without_key = window_without_key and key is None
        guard.auth = 'on' if key is not None else 'off'
        self._took = False

    def subscribe(self, msg_type, topic: str, callback: Callable, qos, max_bytes: int,
                  sender: Optional[int] = None, relayed: bool = False,
                  origin: Optional[Callable[[int], str]] = None, names_sender: bool = True,
                  content: Optional[Callable] = None):
        """Subscribe raw to topic; callback(msg) gets the messages that pass (class docstring).

        sender: the only id allowed to sign on this topic (None: any on the roster); relayed:
        the type carries a relay seal after the sender's block (not checked); origin: the topic
        is an inbox of the relay, origin(sender) the topic the sender published on (the seal
        and the sender's block are checked); names_sender: the message's ``agent_id`` is its
        sender's (not so in a scan, where it names the receiver); content(msg): raises
        msg_conversions.InvalidMessage for a message the node cannot use (bad content).
        """
        channel = self.node.resolve_topic_name(topic)

        def on_data(data: bytes):
            msg = self.receive(channel, data, msg_type, max_bytes, sender, relayed, origin,
                               names_sender, content)
            if msg is not None:
                callback(msg)
        return self.node.create_subscription(msg_type, topic, on_data, qos, raw=True)

    def took_any(self) -> bool:
        """Whether a message passed every check and was taken (with a key: the run started)."""
        return self._took

    def receive(self, channel: str, data: bytes, msg_type, max_bytes: int,
                sender: Optional[int] = None, relayed: bool = False,
                origin: Optional[Callable[[int], str]] = None, names_sender: bool = True,
                content: Optional[Callable] = None):
        """Return the message of data if it passes every check, else None (counted)."""
        signed = self.check(channel, data, max_bytes, sender, relayed, origin, commit=False)
        if signed is False:
            return None
        try:
            msg = deserialize_message(data, msg_type)
        except Exception as error:     # rclpy raises different types for different CDR defects
            self.guard.drop('undecodable', f'{channel}: not a {msg_type.__name__} ({error})')
            return None
        if not self.confirm(channel, signed, msg, names_sender):
            return None
        if content is not None:
            try:
                content(msg)
            except InvalidMessage as error:
                self.guard.drop(error.reason, f'{channel}: {error.detail}')
                return None
        self.verifier.commit(channel)
        self._took = True
        return msg

    def receive_report(self, parser, kind: str, channel: str, data: bytes, lattice,
                       max_bytes: int, sender: Optional[int] = None, relayed: bool = False,
                       origin: Optional[Callable[[int], str]] = None):
        """Return (msg, part) of an agent's radio report if it passes, else None (counted).

        As receive, with the radio's parser (radio_parsing.RadioParser: bounds, then decoding
        shared across the agents of a process) in place of deserialize_message; part may be an
        InvalidMessage the caller drops after its own step checks (such a report does not
        advance the sender's replay counter).
        """
        signed = self.check(channel, data, max_bytes, sender, relayed, origin, commit=False)
        if signed is False:
            return None
        msg, part = parser.parse(kind, data, lattice)
        if msg is None:
            self.guard.drop(part.reason, f'{channel}: {part.detail}')
            return None
        if not self.confirm(channel, signed, msg):
            return None
        if not isinstance(part, InvalidMessage):
            self.verifier.commit(channel)
            self._took = True
        return msg, part

    def check(self, channel: str, data: bytes, max_bytes: int, sender: Optional[int] = None,
              relayed: bool = False, origin: Optional[Callable[[int], str]] = None,
              commit: bool = True):
        """Check size and signature; return the sender's Signed block (None without a key).

        Returns False (counted) when the message must be dropped. commit False: the message
        advances the replay counter only at verifier.commit(channel) (receive does that).
        """
        try:
            if origin is not None:
                signed = self.verifier.verify_delivery(channel, data, origin, max_bytes, commit)
            else:
                signed = self.verifier.verify(channel, data, relayed, sender, max_bytes, commit)
        except AuthError as error:
            self.guard.drop(error.reason, error.detail)
            return False
        self._took = self._took or commit
        return signed

    def confirm(self, channel: str, signed: Optional[Signed], msg,
                names_sender: bool = True) -> bool:
        """Whether msg's own step and sender fields agree with its signature (counted if not).

        Without a key (and window_without_key) the message's step is held to the window instead.
        """
        step = getattr(msg, 'step', None)
        if step is None:
            return True
        agent = getattr(msg, 'agent_id', None) if names_sender else None
        try:
            if signed is None and self.window_without_key:
                self.verifier.check_window(channel, WORLD_SENDER if agent is None else agent,
                                           int(step))
            else:
                self.verifier.confirm(signed, int(step), agent)
        except AuthError as error:
            self.guard.drop(error.reason, error.detail)
            return False
        return True
