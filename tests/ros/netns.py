"""Private network namespaces joined by a bridge: "several hosts" on one machine.

`Hosts(["drv", "ctl", "fc", "py"])` creates one namespace per host plus a hub namespace
holding a Linux bridge; each host gets a veth pair (`eth0` in the host, its peer on the
bridge in the hub) and a private address 10.211.0.<n>/24. Nothing is created in the
machine's own namespace: the veth pairs are made inside the hub namespace, so no link of
the test ever touches the host's interfaces. The hosts have no default route (only the
connected /24 and the multicast range on eth0), so no packet can leave them:
`check_isolated()` asserts that. `close()` removes everything (deleting a namespace
deletes its veth ends).

Needs root and iproute2 (`ip netns`); `unavailable()` says why it cannot run, or None.
"""
import json
import os
import shutil
import subprocess

SUBNET = "10.211.0"


def _ip(*args, ns=None, check=True):
    cmd = ["ip", *(["-n", ns] if ns else []), *args]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if check and r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {r.stderr.strip()}")
    return r


def unavailable():
    """Why network namespaces cannot be used here (None when they can)."""
    if shutil.which("ip") is None:
        return "iproute2 ('ip') is not installed"
    if os.geteuid() != 0:
        return "creating network namespaces needs root (run the test as root, e.g. in CI's container)"
    probe = f"naicprobe{os.getpid()}"
    r = _ip("netns", "add", probe, check=False)
    if r.returncode != 0:
        return f"'ip netns add' failed: {r.stderr.strip()}"
    _ip("netns", "del", probe, check=False)
    return None


class Hosts:
    """Namespaces `<prefix>-<name>` for each host, bridged in `<prefix>-hub`."""

    def __init__(self, names, prefix=None):
        self.prefix = prefix or f"naic{os.getpid() % 100000}"
        self.hub = f"{self.prefix}-hub"
        self.ns = {n: f"{self.prefix}-{n}" for n in names}
        self.addr = {n: f"{SUBNET}.{i + 1}" for i, n in enumerate(names)}
        self.created = []
        try:
            self._create(names)
        except Exception:
            self.close()
            raise

    def _create(self, names):
        for ns in [self.hub, *self.ns.values()]:
            _ip("netns", "add", ns)
            self.created.append(ns)
            _ip("link", "set", "lo", "up", ns=ns)
        _ip("link", "add", "br0", "type", "bridge", ns=self.hub)
        _ip("link", "set", "br0", "up", ns=self.hub)
        for i, n in enumerate(names):
            port = f"p{i}"
            # Made inside the hub; the peer moves straight into the host namespace.
            _ip("link", "add", port, "type", "veth", "peer", "name", "eth0", "netns", self.ns[n], ns=self.hub)
            _ip("link", "set", port, "master", "br0", ns=self.hub)
            _ip("link", "set", port, "up", ns=self.hub)
            _ip("addr", "add", f"{self.addr[n]}/24", "dev", "eth0", ns=self.ns[n])
            _ip("link", "set", "eth0", "up", ns=self.ns[n])
            # Multicast (DDS discovery, 239.255.0.1) goes out of eth0, i.e. onto the bridge;
            # there is no default route.
            _ip("route", "add", "224.0.0.0/4", "dev", "eth0", ns=self.ns[n])

    def exec_prefix(self, name):
        """Command prefix that runs a program in host `name`."""
        return ["ip", "netns", "exec", self.ns[name]]

    def _links(self, ns):
        return json.loads(_ip("-j", "-s", "link", "show", ns=ns).stdout)

    def _peer_ns(self, ns, link):
        """Name of the namespace holding the veth peer of `link` in `ns` (None: this one)."""
        nsid = link.get("link_netnsid")
        if nsid is None:
            return None
        ids = json.loads(_ip("-j", "netns", "list-id", ns=ns).stdout or "[]")
        return next((i.get("name") for i in ids if i.get("nsid") == nsid), f"<unnamed nsid {nsid}>")

    def check_isolated(self):
        """Assert that each host has only lo and eth0, eth0's one peer is its port on the
        hub's bridge, the hub holds only the bridge and those ports, no host has a default
        route or can route to an address outside the test's subnet. Returns a summary."""
        for i, (n, ns) in enumerate(self.ns.items()):
            links = {l["ifname"]: l for l in self._links(ns)}
            assert sorted(links) == ["eth0", "lo"], f"host {n}: links {sorted(links)}"
            assert self._peer_ns(ns, links["eth0"]) == self.hub, f"host {n}: eth0's peer is not in {self.hub}"
            routes = _ip("route", "show", "table", "all", ns=ns).stdout
            assert "default" not in routes, f"host {n} has a default route:\n{routes}"
            for outside in ("1.1.1.1", "192.168.1.1", "10.0.0.1"):
                r = _ip("route", "get", outside, ns=ns, check=False)
                assert r.returncode != 0 and "unreachable" in r.stderr.lower(), \
                    f"host {n} can route to {outside}: {r.stdout}{r.stderr}"
        hub = {l["ifname"]: l for l in self._links(self.hub)}
        ports = {f"p{i}" for i in range(len(self.ns))}
        assert set(hub) == {"lo", "br0", *ports}, f"hub links: {sorted(hub)}"
        for i, ns in enumerate(self.ns.values()):
            p = hub[f"p{i}"]
            assert p.get("master") == "br0" and self._peer_ns(self.hub, p) == ns, p
        routes = _ip("route", "show", "table", "all", ns=self.hub).stdout
        assert "default" not in routes, routes
        return f"{len(self.ns)} hosts on {SUBNET}.0/24, bridge br0 in {self.hub}, no default route, no other link"

    def bridge_bytes(self):
        """Bytes received by the bridge's ports so far (traffic that crossed the bridge)."""
        hub = self._links(self.hub)
        return sum(l["stats64"]["rx"]["bytes"] for l in hub if l["ifname"].startswith("p"))

    def close(self):
        for ns in reversed(self.created):
            _ip("netns", "del", ns, check=False)
        self.created = []
        left = _ip("netns", "list", check=False).stdout
        assert self.prefix + "-" not in left, f"namespaces left behind: {left}"
