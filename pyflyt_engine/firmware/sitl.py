"""One Betaflight SITL process: found, configured, started on free ports, stepped, stopped.

The binary is Betaflight 4.6.0's SITL target built with ``sitl-lockstep.patch``
(:mod:`pyflyt_engine.firmware.build`).  Each process gets its own working directory (the
firmware keeps its settings in ``eeprom.bin`` there) and its own ports, passed in the
environment: ``SITL_UDP_BASE_PORT`` (servo answers on base + 2, state in on base + 3),
``SITL_TCP_BASE_PORT`` (the CLI/MSP of UART1 on base + 1), ``SITL_GYRO_HZ`` (the gyro and
PID rate: the simulator's control rate) and ``SITL_LOCKSTEP=1``.

Configuration is a first, free-running boot: the CLI commands go over UART1's TCP port and
``save`` writes ``eeprom.bin`` (the SITL then exits, as a board reboots).  The file is kept
in a cache keyed by the binary and the commands, so a second process with the same
configuration boots straight into lockstep with it.
"""

from __future__ import annotations

import hashlib
import os
import random
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from pyflyt_engine.errors import PyFlytError
from pyflyt_engine.firmware import packets

#: how long the firmware may take to boot, answer the CLI or answer a tick before it is
#: declared hung (a hung process is the only thing these bounds catch: a healthy one
#: answers a tick in well under a millisecond)
START_TIMEOUT_S = 30.0
TICK_TIMEOUT_S = 20.0


def _die_with_parent() -> None:
    """In the child before exec: Linux sends it SIGTERM when this process dies, so that a
    firmware never outlives the simulator that drives it (a crash, a kill, an unclosed env)."""
    try:
        import ctypes
        import signal

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: stop() and the env's close still end it
        pass


class FirmwareError(PyFlytError, RuntimeError):
    """The flight controller firmware cannot be built, started, configured or stepped:
    the message says which and how to fix it."""


class FirmwareHungError(FirmwareError):
    """A running SITL gave no answer to a tick within ``TICK_TIMEOUT_S``."""


def cache_dir() -> Path:
    """Where built firmware and saved configurations live (``PYFLYT_FIRMWARE_CACHE`` or
    ``~/.cache/pyflyt/firmware``)."""
    root = os.environ.get("PYFLYT_FIRMWARE_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "pyflyt" / "firmware"


def binary_path() -> Path:
    """The patched SITL binary: ``PYFLYT_BETAFLIGHT_SITL`` or the one the build put in the cache.

    Raises:
        FirmwareError: not built yet (the message gives the build command).
    """
    given = os.environ.get("PYFLYT_BETAFLIGHT_SITL")
    path = Path(given) if given else cache_dir() / "betaflight_4.6.0_SITL_lockstep"
    if not path.is_file() or not os.access(path, os.X_OK):
        where = f"PYFLYT_BETAFLIGHT_SITL={given} names no executable file" if given else f"no {path}"
        raise FirmwareError(
            f"the Betaflight SITL firmware is not built ({where}): build it once with "
            "`python -m pyflyt_engine.firmware.build` (needs gcc and make; about a minute), "
            "or point PYFLYT_BETAFLIGHT_SITL at a binary built with pyflyt_engine/firmware/sitl-lockstep.patch"
        )
    return path


def _udp_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def _tcp_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def free_ports(rng: random.Random | None = None, tries: int = 200) -> tuple[int, int, socket.socket]:
    """A UDP base and a TCP base whose ports are free, and the bound socket of the servo port.

    The servo socket (UDP base + 2) stays bound: it is this side's end of the link.
    """
    draw = rng or random.SystemRandom()
    for _ in range(tries):
        udp = draw.randrange(20000, 40000, 10)
        tcp = draw.randrange(40000, 60000, 10)
        if not all(_udp_free(udp + k) for k in (1, 3, 4)) or not all(_tcp_free(tcp + k) for k in range(1, 9)):
            continue
        servo = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            servo.bind(("127.0.0.1", udp + 2))
        except OSError:
            servo.close()
            continue
        return udp, tcp, servo
    raise FirmwareError("no free ports for a Betaflight SITL (UDP 20000-40000, TCP 40000-60000): close other instances")


class SITLProcess:
    """One running SITL (free-running for configuration, or in lockstep).

    Args:
        workdir: its working directory (its ``eeprom.bin``).
        gyro_hz: its gyro and PID rate [Hz].
        lockstep: whether its clock follows the state packets.
        ports: (UDP base, TCP base, bound servo socket); free ones when None.
    """

    def __init__(
        self,
        workdir: Path,
        gyro_hz: int,
        lockstep: bool,
        ports: tuple[int, int, socket.socket] | None = None,
    ) -> None:
        self.workdir = Path(workdir)
        self.binary = binary_path()
        self.udp_base, self.tcp_base, self.servo = ports if ports is not None else free_ports()
        self.servo.settimeout(TICK_TIMEOUT_S)
        self.state = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.log_path = self.workdir / "sitl.log"
        env = dict(
            os.environ,
            SITL_UDP_BASE_PORT=str(self.udp_base),
            SITL_TCP_BASE_PORT=str(self.tcp_base),
            SITL_GYRO_HZ=str(int(gyro_hz)),
            SITL_LOCKSTEP="1" if lockstep else "0",
        )
        self._log = open(self.log_path, "wb")
        try:
            self.process = subprocess.Popen(
                [str(self.binary), "127.0.0.1"],
                cwd=self.workdir,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=self._log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
                preexec_fn=_die_with_parent,
            )
        except OSError as error:
            self._log.close()
            self._close_sockets()
            raise FirmwareError(f"cannot start the Betaflight SITL {self.binary}: {error}") from None
        try:
            self._wait_ready()
        except BaseException:
            self.stop()
            raise

    # ----------------------------------------------------------- lifecycle

    def log(self) -> str:
        """What the firmware printed so far."""
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""

    def _wait_ready(self) -> None:
        """Until the firmware says it listens on UART1's TCP port (on stderr, unbuffered: the
        end of its start-up); a failed bind or an early exit is an error naming the port."""
        deadline = time.monotonic() + START_TIMEOUT_S
        listening = f"bind port {self.tcp_base + 1} for UART1\n"
        while True:
            text = self.log()
            if "failed!!" in text:
                raise FirmwareError(
                    f"the Betaflight SITL could not bind its ports (UDP {self.udp_base + 1}-{self.udp_base + 4}, "
                    f"TCP {self.tcp_base + 1}): another process holds one; stop it or retry "
                    f"(its output: {text.strip()[-200:]!r})"
                )
            if listening in text:
                return
            if self.process.poll() is not None:
                raise FirmwareError(
                    f"the Betaflight SITL exited during start-up (code {self.process.returncode}); "
                    f"its output: {text.strip()[-400:]!r}"
                )
            if time.monotonic() > deadline:
                raise FirmwareError(
                    f"the Betaflight SITL did not open its ports within {START_TIMEOUT_S:.0f} s "
                    "(the machine may be overloaded, or the binary is not the patched one); "
                    f"its output: {text.strip()[-300:]!r}"
                )
            time.sleep(0.005)

    def _close_sockets(self) -> None:
        for s in (getattr(self, "servo", None), getattr(self, "state", None)):
            if s is not None:
                s.close()

    def stop(self) -> None:
        """Stop the process (and its threads) and release its ports; safe to call twice."""
        process = getattr(self, "process", None)
        if process is not None and process.poll() is None:
            process.send_signal(signal.SIGCONT)  # a stopped process takes SIGTERM only once continued
            process.terminate()
            try:
                process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        if not self._log.closed:
            self._log.close()
        self._close_sockets()

    def wait_exit(self, timeout: float = START_TIMEOUT_S) -> int:
        """Wait for the process to exit by itself (after ``save``); its exit code."""
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.stop()
            raise FirmwareError(f"the Betaflight SITL did not restart after `save` within {timeout:.0f} s") from None

    # ----------------------------------------------------------------- CLI

    def _cli_link(self, deadline: float) -> socket.socket:
        """A TCP link to UART1 in CLI mode: '#' enters the CLI once the firmware's serial task
        runs, so it is sent until the banner comes (the port takes one client: a link the
        firmware drops is made again)."""
        while True:
            try:
                link = socket.create_connection(("127.0.0.1", self.tcp_base + 1), timeout=1.0)
            except OSError:
                link = None
            if link is not None:
                banner = b""
                try:
                    while time.monotonic() < deadline:
                        link.sendall(b"#")
                        link.settimeout(0.5)
                        try:
                            banner += link.recv(4096)
                        except TimeoutError:
                            continue
                        if b"Entering CLI Mode" in banner and banner.endswith(b"# "):
                            link.settimeout(START_TIMEOUT_S)
                            return link
                except OSError:
                    pass
                link.close()
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise FirmwareError(
                    f"the Betaflight CLI did not answer within {START_TIMEOUT_S:.0f} s on TCP port {self.tcp_base + 1} "
                    f"(log: {self.log_path})"
                )
            time.sleep(0.1)

    def cli(self, commands: Sequence[str]) -> str:
        """Run CLI commands over UART1 (``save`` last: the firmware saves and exits).

        Raises:
            FirmwareError: the CLI did not answer, or refused a command (named).
        """
        transcript = []
        with self._cli_link(time.monotonic() + START_TIMEOUT_S) as link:

            def until_prompt() -> str:
                data = b""
                while not data.endswith(b"\n# "):
                    chunk = link.recv(4096)
                    if not chunk:
                        break
                    data += chunk
                return data.decode(errors="replace")

            for command in commands:
                link.sendall(command.encode() + b"\r\n")
                if command.strip() == "save":  # the firmware saves, says so and reboots (exits)
                    said = b""
                    while b"Rebooting" not in said:
                        chunk = link.recv(4096)
                        if not chunk:
                            break
                        said += chunk
                    transcript.append(said.decode(errors="replace"))
                    break
                answer = until_prompt()
                transcript.append(answer)
                if "###ERROR" in answer or "Invalid" in answer:
                    raise FirmwareError(f"the Betaflight CLI refused `{command}`: {answer.strip()}")
        return "\n".join(transcript)

    # ------------------------------------------------------------ lockstep

    def tick(self, datagram: bytes) -> tuple[float, float, float, float]:
        """Send one tick, wait for its answer: Betaflight's motors 1-4 in [0, 1].

        Raises:
            FirmwareError: the process exited, or gave no answer within ``TICK_TIMEOUT_S``.
        """
        self.state.sendto(datagram, ("127.0.0.1", self.udp_base + 3))
        try:
            answer = self.servo.recv(64)
        except TimeoutError:
            alive = self.process.poll() is None
            raise (FirmwareHungError if alive else FirmwareError)(
                f"the Betaflight SITL gave no motor outputs within {TICK_TIMEOUT_S:.0f} s "
                f"({'still running: hung' if alive else f'exited with code {self.process.returncode}'}); "
                f"its last output: {self.log()[-300:]!r}"
            ) from None
        if len(answer) != packets.SERVO.size:
            raise FirmwareError(f"the Betaflight SITL answered {len(answer)} bytes, not a servo_packet")
        return packets.motors_from_servo(answer)


def _start_retrying(start, tries: int = 3) -> SITLProcess:
    """``start()``, again on other free ports when a port it drew was taken meanwhile (another
    process may bind a port between the check and the firmware's bind)."""
    for attempt in range(tries):
        try:
            return start()
        except FirmwareError as error:
            if "could not bind" not in str(error) or attempt == tries - 1:
                raise
    raise AssertionError("unreachable")


def configured_eeprom(commands: Sequence[str], gyro_hz: int) -> Path:
    """The ``eeprom.bin`` the commands produce, made once and cached by binary and commands."""
    binary = binary_path()
    digest = hashlib.sha256()
    digest.update(hashlib.sha256(binary.read_bytes()).digest())
    digest.update("\n".join(commands).encode())
    target = cache_dir() / "eeprom" / f"{digest.hexdigest()[:24]}.bin"
    if target.is_file():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="pyflyt-bf-config-") as work:
        process = _start_retrying(lambda: SITLProcess(Path(work), gyro_hz, lockstep=False))
        try:
            process.cli([*commands, "save"])
            process.wait_exit()
        finally:
            process.stop()
        saved = Path(work) / "eeprom.bin"
        if not saved.is_file():
            raise FirmwareError(f"the Betaflight SITL saved no eeprom.bin; its output: {process.log()[-400:]!r}")
        partial = target.with_suffix(f".{os.getpid()}.part")
        shutil.copyfile(saved, partial)
        os.replace(partial, target)  # atomic: parallel envs may race to make the same file
    return target


class LockstepSITL:
    """A configured SITL in lockstep, in its own temporary directory (removed by :meth:`close`)."""

    def __init__(self, commands: Sequence[str], gyro_hz: int) -> None:
        eeprom = configured_eeprom(commands, gyro_hz)
        self._dir = Path(tempfile.mkdtemp(prefix="pyflyt-bf-"))
        shutil.copyfile(eeprom, self._dir / "eeprom.bin")
        try:
            self.process = _start_retrying(lambda: SITLProcess(self._dir, gyro_hz, lockstep=True))
        except BaseException:
            shutil.rmtree(self._dir, ignore_errors=True)
            raise

    def tick(self, datagram: bytes) -> tuple[float, float, float, float]:
        return self.process.tick(datagram)

    def close(self) -> None:
        self.process.stop()
        shutil.rmtree(self._dir, ignore_errors=True)
