"""Reads the virtual table's registers as a third party would (stdlib only: a raw Modbus TCP
client, addresses from the device file read with tomllib, not from our code). It only reads:
it never writes the heartbeat, so it does not keep the controller's host watchdog fed.

    from modbus_peek import TablePeek
    p = TablePeek(device_toml, port=1502)
    s = p.read()   # {"angles_deg": [...], "moving": [...], "interlock_closed": ..., "estop": ...}
"""
import socket
import struct
import tomllib


class TablePeek:
    def __init__(self, device_toml, port, host="127.0.0.1"):
        with open(device_toml, "rb") as f:
            d = tomllib.load(f)
        self.regs = d["registers"]
        self.bits = d["status_bits"]
        self.unit = d["transport"].get("unit_id", 1)
        if self.regs["word_order"] != "high-first":
            raise SystemExit("modbus_peek reads high-first f32 registers only")
        self.addr = (host, port)
        self.tid = 0
        self.sock = None  # one connection for every read (a read is several requests)

    def holding(self, address, count):
        """Function 3 (read holding registers): count u16 values from address."""
        self.tid = (self.tid + 1) & 0xFFFF
        pdu = struct.pack(">BHH", 3, address, count)
        req = struct.pack(">HHHB", self.tid, 0, len(pdu) + 1, self.unit) + pdu
        if self.sock is None:
            self.sock = socket.create_connection(self.addr, timeout=2.0)
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        try:
            self.sock.sendall(req)
            head = self._recv(self.sock, 7)
            _, _, length, _ = struct.unpack(">HHHB", head)
            body = self._recv(self.sock, length - 1)
        except (OSError, SystemExit):
            self.sock.close()
            self.sock = None
            raise
        if body[0] != 3:
            raise SystemExit("Modbus exception reply: %s" % body.hex())
        return list(struct.unpack(">%dH" % count, body[2:2 + 2 * count]))

    @staticmethod
    def _recv(s, n):
        data = b""
        while len(data) < n:
            chunk = s.recv(n - len(data))
            if not chunk:
                raise SystemExit("Modbus server closed the connection")
            data += chunk
        return data

    def _field(self, f):
        if f.get("bank", "holding") != "holding":
            raise SystemExit("modbus_peek reads holding registers only")
        if f["type"] == "f32":
            hi, lo = self.holding(f["address"], 2)
            return struct.unpack(">f", struct.pack(">HH", hi, lo))[0]
        return self.holding(f["address"], 1)[0]

    def read(self):
        """The controller's state: angles (deg, as the controller reports them), per-axis
        moving bits, interlock and emergency-stop bits of the global status word.

        One read is several requests, so not one instant: each axis's status word is read
        before its position. An axis read as at rest then reports the angle it rests at; read
        the other way round, the angle could come from before the stop, while it still moved
        (braking at the reference table's 100 deg/s^2, 5 ms before rest is 1.25e-3 deg short of
        it: host_watchdog.sh's 'at rest from ... at' check failed once on a loaded machine,
        most likely so)."""
        st = self._field(self.regs["status"])
        out = {"angles_deg": [], "moving": [],
               "interlock_closed": bool((st >> self.bits["interlock_closed"]) & 1),
               "interlock_tripped": bool((st >> self.bits["interlock_tripped"]) & 1),
               "estop": bool((st >> self.bits["estop"]) & 1)}
        for ax in self.regs["axis"]:
            out["moving"].append(bool((self._field(ax["status"]) >> self.bits["axis_moving"]) & 1))
            out["angles_deg"].append(self._field(ax["position"]))
        return out
