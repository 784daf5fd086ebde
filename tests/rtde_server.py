"""A UR controller's RTDE interface on loopback, written from UR's RTDE guide, for the real ``ur_rtde`` client.

Every package is ``uint16 size`` (header included), ``uint8 type``, then the payload, big-endian.
What a client of protocol version 2 sends and what the controller answers:

- ``V`` RTDE_REQUEST_PROTOCOL_VERSION: ``uint16 version`` -> ``uint8 accepted`` (2 is accepted);
- ``v`` RTDE_GET_URCONTROL_VERSION: nothing -> ``uint32 major, minor, bugfix, build``
  (major 5: an e-Series, which ``ur_rtde`` reads at 500 Hz);
- ``O`` RTDE_CONTROL_PACKAGE_SETUP_OUTPUTS: ``double frequency`` then the variable names separated
  by commas -> ``uint8 recipe id`` then their types separated by commas (``NOT_FOUND`` for a name
  the controller does not publish);
- ``S`` RTDE_CONTROL_PACKAGE_START and ``P`` RTDE_CONTROL_PACKAGE_PAUSE: nothing -> ``uint8 accepted``;
- ``U`` RTDE_DATA_PACKAGE (controller to client, once per cycle after ``S``): ``uint8 recipe id``
  then each variable of the recipe in its type's format;
- ``M`` RTDE_TEXT_MESSAGE (controller to client): ``uint8 length, message, uint8 length, source,
  uint8 warning level``.

``ur_rtde``'s constructor holds Python's GIL until the handshake is over, so the controller runs in
its own process (:class:`ControllerProcess`, this file run as a script). ``RTDEReceiveInterface(host)``
connects to port 30004 only (it takes no port and
opens neither the dashboard, 29999, nor the script ports, 30002/30003), so the server binds
127.0.0.1:30004; :class:`RtdeController` raises ``OSError`` when that port is taken (the tests
skip). What it publishes is scripted (:class:`Script`): the controller's clock, the joints, the
built-in sensor's raw wrench, and a connection dropped after some samples.
"""

from __future__ import annotations

import json
import socket
import struct
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: The TCP port of RTDE on every UR controller (the one ``ur_rtde`` connects to).
RTDE_PORT = 30004
#: The protocol version this controller accepts.
PROTOCOL = 2
#: Each type's struct format (big-endian), from the RTDE guide's table of data types.
FORMATS = {
    "BOOL": "?",
    "UINT8": "B",
    "UINT32": "I",
    "UINT64": "Q",
    "INT32": "i",
    "DOUBLE": "d",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "VECTOR6INT32": "6i",
    "VECTOR6UINT32": "6I",
}
#: The output variables a client may ask for (the guide's list of controller outputs), and their types.
OUTPUTS = {
    "timestamp": "DOUBLE",
    **dict.fromkeys(
        [
            "target_q",
            "target_qd",
            "target_qdd",
            "target_current",
            "target_moment",
            "actual_q",
            "actual_qd",
            "actual_current",
            "joint_control_output",
            "actual_TCP_pose",
            "actual_TCP_speed",
            "actual_TCP_force",
            "target_TCP_pose",
            "target_TCP_speed",
            "joint_temperatures",
            "actual_joint_voltage",
            "ft_raw_wrench",
            "payload_inertia",
        ],
        "VECTOR6D",
    ),
    **dict.fromkeys(["actual_tool_accelerometer", "payload_cog", "elbow_position", "elbow_velocity"], "VECTOR3D"),
    **dict.fromkeys(
        [
            "actual_execution_time",
            "speed_scaling",
            "target_speed_fraction",
            "actual_momentum",
            "actual_main_voltage",
            "actual_robot_voltage",
            "actual_robot_current",
            "standard_analog_input0",
            "standard_analog_input1",
            "standard_analog_output0",
            "standard_analog_output1",
            "payload",
            "tool_analog_input0",
            "tool_analog_input1",
            "tool_output_current",
            "tool_temperature",
        ],
        "DOUBLE",
    ),
    **dict.fromkeys(["actual_digital_input_bits", "actual_digital_output_bits"], "UINT64"),
    **dict.fromkeys(["robot_mode", "safety_mode", "tool_mode", "tool_output_voltage"], "INT32"),
    **dict.fromkeys(["runtime_state", "robot_status_bits", "safety_status_bits", "output_bit_registers0_to_31"], "UINT32"),
    "joint_mode": "VECTOR6INT32",
}
#: Values other than zero: a running arm in normal safety mode, a program playing, full speed.
STATE = {
    "robot_mode": 7,
    "safety_mode": 1,
    "runtime_state": 2,
    "robot_status_bits": 0b1111,
    "speed_scaling": 1.0,
    "target_speed_fraction": 1.0,
}


def output_type(name: str) -> str:
    """The RTDE type of an output variable, or ``NOT_FOUND``."""
    if name.startswith("output_int_register_"):
        return "INT32"
    if name.startswith("output_double_register_"):
        return "DOUBLE"
    if name.startswith("output_bit_register_"):
        return "BOOL"
    return OUTPUTS.get(name, "NOT_FOUND")


def package(kind: str, payload: bytes = b"") -> bytes:
    """One RTDE package: ``uint16 size`` (the 3 header bytes included), ``uint8 type``, the payload."""
    return struct.pack(">HB", 3 + len(payload), ord(kind)) + payload


def text_message(message: str, source: str = "fts-calib test controller", level: int = 1) -> bytes:
    """An RTDE_TEXT_MESSAGE package (protocol 2): message and source each after its uint8 length, the warning level."""
    m, s = message.encode(), source.encode()
    return package("M", struct.pack(">B", len(m)) + m + struct.pack(">B", len(s)) + s + struct.pack(">B", level))


@dataclass
class Script:
    """What the controller publishes after a client's start request, one sample per data package.

    Attributes:
        time: The controller's clock of each sample, shape (n,) [s since the controller started].
        q: The joints (``actual_q`` and ``target_q``), shape (n, 6) [rad].
        wrench: The built-in sensor's raw wrench (``ft_raw_wrench``), shape (n, 6) [N, N·m].
        period_s: Wall time between two data packages [s].
        close_after: Send this many samples, then drop the connection (a lost controller); None: all,
            then the last one again each period, its time unchanged (connected, nothing new), until
            the client goes.
    """

    time: np.ndarray
    q: np.ndarray
    wrench: np.ndarray
    period_s: float = 0.002
    close_after: int | None = None


class RtdeController:
    """An RTDE server on ``host:port`` answering every client as a UR e-Series controller would (a context manager).

    Args:
        script: What each client's data packages carry after its start request.
        host: The address to bind.
        port: The port to bind (RTDE's own: the real client connects there and nowhere else).
        version: The controller's software version (major, minor, bugfix, build).

    Attributes:
        requests: Each package received, as (type letter, payload), in order, over all clients.
        sent: Data packages sent, over all clients.
        connections: Clients accepted (the project's handshake probe, then ``ur_rtde``).

    Raises:
        OSError: The port is taken.
    """

    def __init__(self, script: Script, host: str = "127.0.0.1", port: int = RTDE_PORT, version=(5, 11, 0, 0)):
        self.script, self.version = script, tuple(version)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.sock.bind((host, port))
        except OSError:
            self.sock.close()
            raise
        self.sock.listen(4)
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        self.requests: list[tuple[str, bytes]] = []
        self.sent = 0
        self.connections = 0
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._accept = threading.Thread(target=self._serve, name="rtde-controller", daemon=True)
        self._accept.start()

    def __enter__(self) -> RtdeController:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop serving; close the listening socket and every client."""
        self._stop.set()
        self._accept.join(timeout=5.0)
        for thread in self._threads:
            thread.join(timeout=5.0)
        self.sock.close()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                client, _ = self.sock.accept()
            except OSError:
                continue
            self.connections += 1
            thread = threading.Thread(target=self._client, args=(client,), name="rtde-client", daemon=True)
            self._threads.append(thread)
            thread.start()

    def _client(self, client: socket.socket) -> None:
        """Answer one client's requests; stream its data packages from a start request on."""
        client.settimeout(0.05)
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # one package per cycle, not batched by Nagle's algorithm
        send_lock, streaming = threading.Lock(), threading.Event()
        closed = threading.Event()
        recipe: list[str] = []
        streamer: threading.Thread | None = None
        buffer = b""
        try:
            while not self._stop.is_set() and not closed.is_set():
                try:
                    part = client.recv(4096)
                except TimeoutError:
                    continue
                if not part:
                    break
                buffer += part
                while len(buffer) >= 3 and len(buffer) >= struct.unpack(">H", buffer[:2])[0]:
                    size, kind = struct.unpack(">HB", buffer[:3])
                    payload, buffer = buffer[3:size], buffer[size:]
                    letter = chr(kind)
                    self.requests.append((letter, payload))
                    if letter == "V":
                        answer = package("V", struct.pack(">B", struct.unpack(">H", payload)[0] == PROTOCOL))
                    elif letter == "v":
                        answer = package("v", struct.pack(">IIII", *self.version))
                    elif letter == "O":
                        names = payload[8:].decode().split(",")
                        recipe = [name for name in names if name]  # a trailing comma is no variable
                        answer = package("O", struct.pack(">B", 1) + ",".join(map(output_type, recipe)).encode())
                    elif letter in "SP":
                        answer = package(letter, struct.pack(">B", 1))
                    else:
                        continue
                    with send_lock:
                        client.sendall(answer)
                    if letter == "S" and streamer is None:
                        streaming.set()
                        streamer = threading.Thread(target=self._stream, args=(client, recipe, send_lock, streaming, closed), daemon=True)
                        streamer.start()
                    elif letter == "P":
                        streaming.clear()
        except OSError:
            pass
        finally:
            closed.set()
            if streamer is not None:
                streamer.join(timeout=5.0)
            client.close()

    def _stream(self, client, recipe, send_lock, streaming, closed) -> None:
        """Send the script's samples as data packages, one per ``period_s``; drop the connection after ``close_after``."""
        script = self.script
        formats = ">B" + "".join(FORMATS[output_type(name)] for name in recipe)
        count = len(script.time) if script.close_after is None else min(script.close_after, len(script.time))
        with send_lock:
            client.sendall(text_message("RTDE streaming started"))
        due = time.monotonic()
        k = 0
        while not closed.is_set() and not self._stop.is_set():
            while not streaming.is_set() and not closed.is_set():
                time.sleep(0.01)
            if k == count and script.close_after is not None:
                break
            row = min(k, count - 1)  # after the script: its last sample again, time unchanged (nothing new)
            values = []
            for name in recipe:
                if name == "timestamp":
                    values.append(float(script.time[row]))
                elif name in ("actual_q", "target_q"):
                    values.extend(float(v) for v in script.q[row])
                elif name == "ft_raw_wrench":
                    values.extend(float(v) for v in script.wrench[row])
                else:
                    fmt = FORMATS[output_type(name)]
                    width = int(fmt[:-1]) if len(fmt) > 1 else 1
                    values.extend([STATE.get(name, 0)] * width)
            try:
                with send_lock:
                    client.sendall(package("U", struct.pack(formats, 1, *values)))
            except OSError:
                return
            if k < count:
                self.sent += 1
                k += 1
            due += script.period_s
            pause = due - time.monotonic()
            if pause > 0:
                time.sleep(pause)
        if script.close_after is not None:
            closed.set()
            try:
                client.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass


class ControllerProcess:
    """:class:`RtdeController` in a child process (a context manager), for a client that holds the GIL.

    Args:
        script: What the controller publishes.
        workdir: A folder for the script's file.

    Attributes:
        port: The port it listens on.
        summary: After :meth:`close`: ``sent``, ``connections`` and ``requests`` (the type letters, in order).

    Raises:
        OSError: The port is taken (the child's words).
    """

    def __init__(self, script: Script, workdir: Path):
        path = Path(workdir) / "rtde_script.npz"
        np.savez(path, time=script.time, q=script.q, wrench=script.wrench)
        options = {"period_s": script.period_s, "close_after": script.close_after}
        command = [sys.executable, str(Path(__file__).resolve()), str(path), json.dumps(options)]
        self.child = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.child.stdout is not None and self.child.stdin is not None
        first = self.child.stdout.readline().split(maxsplit=1)
        if not first or first[0] != "listening":
            self.child.wait(timeout=10.0)
            raise OSError(first[1].strip() if len(first) > 1 else "the RTDE controller did not start")
        self.port = int(first[1])
        self.summary: dict = {}

    def __enter__(self) -> ControllerProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the child (it stops when its standard input closes) and read its summary."""
        if self.child.returncode is not None:
            return
        out, _ = self.child.communicate(timeout=10.0)  # closes its standard input first
        if out.strip():
            self.summary = json.loads(out.strip().splitlines()[-1])


def _main(argv: list[str]) -> None:
    """``rtde_server.py SCRIPT.npz OPTIONS_JSON``: serve until standard input closes; print a summary as JSON."""
    data = np.load(argv[0])
    script = Script(data["time"], data["q"], data["wrench"], **json.loads(argv[1]))
    try:
        controller = RtdeController(script)
    except OSError as exc:
        print("taken", f"cannot bind 127.0.0.1:{RTDE_PORT}: {exc.strerror or exc}", flush=True)
        return
    print("listening", controller.port, flush=True)
    sys.stdin.read()
    controller.close()
    letters = [letter for letter, _ in controller.requests]
    print(json.dumps({"sent": controller.sent, "connections": controller.connections, "requests": letters}), flush=True)


if __name__ == "__main__":
    _main(sys.argv[1:])
