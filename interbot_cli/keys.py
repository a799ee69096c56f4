"""`interbot keys`: the certificates behind the secure robot and tablet links (docs/security.md).

    interbot keys init DIR                       CA + robot interbot1, station, observer
    interbot keys add-robot NAME [--host H] [--dir DIR]
    interbot keys add-station NAME [--dir DIR]
    interbot keys add-observer NAME [--dir DIR]
    interbot keys add-router NAME [--host H] [--dir DIR]   a building's router (interbot router)
    interbot keys revoke NAME [--dir DIR]
    interbot keys list [--dir DIR]
    interbot keys export NAME OUTDIR [--dir DIR]  what NAME's machine needs, without ca.key

``--dir`` defaults to ``$INTERBOT_KEYS``, else ``~/.config/interbot/keys``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from interbot_link.keys import LEAF_DAYS, KeysError, KeyStore

DEFAULT_DIR = Path("~/.config/interbot/keys")


def default_dir() -> Path:
    return Path(os.environ.get("INTERBOT_KEYS", str(DEFAULT_DIR))).expanduser()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="keys_command", required=True, metavar="ACTION")
    p_init = sub.add_parser(
        "init", help="create a CA and certificates for a robot, station, observer"
    )
    p_init.add_argument("dir", type=Path, help="new key directory")
    p_init.add_argument("--robot", default="interbot1", help="the first robot's id")
    p_init.add_argument("--days", type=int, default=LEAF_DAYS, help="certificate lifetime")
    for role in ("robot", "station", "observer", "router"):
        p_add = sub.add_parser(f"add-{role}", help=f"issue a certificate for a new {role}")
        p_add.add_argument("name", help="its name (for a robot: its robot id)")
        p_add.add_argument(
            "--host",
            action="append",
            default=[],
            help="extra IP address or DNS name in the certificate (repeatable)",
        )
        p_add.add_argument("--days", type=int, default=LEAF_DAYS, help="certificate lifetime")
        p_add.add_argument("--dir", type=Path, default=None, help="key directory")
    p_rev = sub.add_parser("revoke", help="revoke a member (restart robots and stations after)")
    p_rev.add_argument("name")
    p_rev.add_argument("--dir", type=Path, default=None, help="key directory")
    p_exp = sub.add_parser("export", help="copy what one member's machine needs (no ca.key)")
    p_exp.add_argument("name")
    p_exp.add_argument("target", type=Path, help="new directory to copy to")
    p_exp.add_argument("--dir", type=Path, default=None, help="key directory")
    p_list = sub.add_parser("list", help="list the members and their state")
    p_list.add_argument("--dir", type=Path, default=None, help="key directory")


def run(args: argparse.Namespace) -> int:
    action = args.keys_command
    try:
        if action == "init":
            members = ((args.robot, "robot"), ("station", "station"), ("observer", "observer"))
            store = KeyStore.init(args.dir, members, days=args.days)
            print(f"created a CA and certificates in {store.dir}:")
            _print_members(store)
            print(
                "next: interbot-daemon --security DIR --listen tls/HOST:7447 on the robot, "
                "interbot-base-station --security DIR --connect tls/HOST:7447 on the station "
                "(`interbot keys export NAME OUTDIR` gathers each one's files, without ca.key)"
            )
            return 0
        store = KeyStore(args.dir or default_dir())
        if action.startswith("add-"):
            member = store.add(args.name, action[4:], tuple(args.host), days=args.days)
            print(
                f"issued {store.dir / (member.name + '.crt')} ({member.role}, until {member.not_after})"
            )
            print("restart the robots and stations (with the updated directory) to admit it")
        elif action == "revoke":
            member = store.revoke(args.name)
            print(f"revoked {member.role} {member.name}; restart the robots and stations to apply")
        elif action == "export":
            out = store.export(args.name, args.target)
            print(f"exported {args.name} to {out}: use it as --security {out} on that machine")
        elif action == "list":
            _print_members(store)
        return 0
    except KeysError as exc:
        print(f"interbot keys: {exc}", file=sys.stderr)
        return 2


def _print_members(store: KeyStore) -> None:
    for name, m in sorted(store.members.items()):
        state = "REVOKED" if m.revoked else f"valid until {m.not_after}"
        print(f"  {name:<16} {m.role:<9} {state}  sha256 {m.sha256[:16]}...")
