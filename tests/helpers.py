"""Synthetic ground truth shared by the tests (independent of the code under test)."""

import time

import numpy as np

from .paper import TABLE_1

GRAVITY = 9.81  # [m/s^2]

#: The paper's projection (eq 6), typed again so that the truth does not come from the code under test.
P_PAPER = np.array(
    [
        [0, -1, 0, -1, 0, -1, 0, -1],
        [0, 0, 1, 0, 0, 0, -1, 0],
        [1, 0, 0, 0, -1, 0, 0, 0],
        [1, 0, 1, 0, 1, 0, 1, 0],
        [0, 0, 0, -1, 0, 0, 0, 1],
        [0, -1, 0, 0, 0, 1, 0, 0],
    ],
    dtype=float,
)

#: True C_bar: Table 1 of the paper projected (C_bar = Table1 @ pinv(P)).
C_BAR_TRUE = TABLE_1 @ np.linalg.pinv(P_PAPER)

#: Chosen wrench offsets, [N, N, N, N m, N m, N m].
D_TRUE = np.array([1.5, -2.0, 0.7, 0.12, -0.08, 0.05])

#: Three non-collinear tool centres of mass in the sensor frame, [m], and the mass, [kg].
TOOL_MASS = 2.0
COMS = np.array([[0.12, 0.0, 0.0], [0.08, 0.06, 0.0], [0.08, 0.0, 0.06]])


def random_gravity(n: int, rng: np.random.Generator) -> np.ndarray:
    """Gravity vectors of norm 9.81 in uniformly random directions, shape (n, 3)."""
    v = rng.standard_normal((n, 3))
    return GRAVITY * v / np.linalg.norm(v, axis=1, keepdims=True)


def tool_wrench(mass: float, com: np.ndarray, g_sensor: np.ndarray) -> np.ndarray:
    """Eqs 17-18 written out: F = m g, M = c x F, component by component."""
    F = mass * g_sensor
    cx, cy, cz = com
    M = np.stack([cy * F[:, 2] - cz * F[:, 1], cz * F[:, 0] - cx * F[:, 2], cx * F[:, 1] - cy * F[:, 0]], axis=1)
    return np.hstack([F, M])


def strains_eq22(C_bar: np.ndarray, D: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Strains from wrenches by eq 22 and the minimum-norm lift Delta = pinv(P) Delta_bar."""
    bar = np.linalg.solve(C_bar, (W - D).T).T
    return bar @ np.linalg.pinv(P_PAPER).T


def paper_simulation(n_per_config: int, rng: np.random.Generator, noise_std: float = 0.0):
    """Wrenches and strains of the paper's simulation validation, config after config.

    Returns (W (3n, 6), strains (3n, 8), config index (3n,)).
    """
    Ws, Ss, idx = [], [], []
    for k, com in enumerate(COMS):
        W = tool_wrench(TOOL_MASS, com, random_gravity(n_per_config, rng))
        S = strains_eq22(C_BAR_TRUE, D_TRUE, W)
        if noise_std:
            S = S + noise_std * rng.standard_normal(S.shape)
        Ws.append(W)
        Ss.append(S)
        idx.append(np.full(n_per_config, k))
    return np.vstack(Ws), np.vstack(Ss), np.concatenate(idx)


POLL_S = 0.005  # [s] how often a wait looks again for its event
DEADLINE_S = 60.0  # [s] how long a wait may take before the test fails


def wait_for(condition, what: str, timeout_s: float = DEADLINE_S) -> None:
    """Poll ``condition`` until it holds; fail after ``timeout_s`` [s] saying what was awaited."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"waited {timeout_s:g} s for {what}"
        time.sleep(POLL_S)


class FakeRtdeServer:
    """A TCP server on 127.0.0.1 (port 0) standing in for a UR controller's RTDE port.

    ``answer=True`` answers RTDE's protocol-version request as a controller does
    (``>HBB``: size 4, type 'V', accepted); ``answer=False`` accepts the connection and
    says nothing (the case that must not hang). It serves until closed (a context manager).
    """

    def __init__(self, answer: bool = True):
        import socket
        import threading

        self.answer = answer
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(4)
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        self._stop = threading.Event()
        self._clients = []
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self):
        import struct

        while not self._stop.is_set():
            try:
                client, _ = self.sock.accept()
            except OSError:
                continue
            self._clients.append(client)
            if self.answer:
                client.settimeout(5.0)
                request = client.recv(5)
                if len(request) == 5 and request[2] == 86:
                    client.sendall(struct.pack(">HBB", 4, 86, 1))

    def close(self):
        self._stop.set()
        self._thread.join(timeout=5.0)
        for client in self._clients:
            client.close()
        self.sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def live_calibrate(output, *extra: str, address: str = "127.0.0.1:0") -> list[str]:
    """The command line of a live calibration of the UR5 with the paper's tool: ``calibrate udp://ADDRESS ... -o OUTPUT``."""
    return ["calibrate", f"udp://{address}", "--robot", "ur5", "--tool", "paper_tool", "-o", str(output), *extra]
