#!/usr/bin/env python3
"""Checks accesses to a drive's objects against its EDS, as the `canopen` library loads it.

Reads a JSON list from stdin, each item {"index", "sub", "access", "bits"}: access "write" or
"read" (by SDO, `bits` the size transferred) or "rpdo" / "tpdo" (mapped into that PDO with
`bits` as the mapped length). Prints one line per access the EDS does not allow, naming the
object and why, then "checked N accesses"; exits 1 if any was refused.

Usage: eds_access.py EDS_FILE < accesses.json
"""

import json
import sys

import canopen


def refusal(od, a):
    """Why the EDS does not allow access `a`, or None."""
    try:
        obj = od[a["index"]]
        if not isinstance(obj, canopen.objectdictionary.ODVariable):
            obj = obj[a["sub"]]
    except KeyError:
        return "not in the object dictionary"
    kind, bits = a["access"], a["bits"]
    if kind in ("write", "rpdo") and not obj.writable:
        return "access type %s is not writable" % obj.access_type
    if kind in ("read", "tpdo") and not obj.readable:
        return "access type %s is not readable" % obj.access_type
    if kind in ("rpdo", "tpdo") and not obj.pdo_mappable:
        return "not PDO-mappable"
    if bits != len(obj):
        return "%d bits accessed, the object's data type has %d" % (bits, len(obj))
    return None


def main(argv):
    od = canopen.import_od(argv[1], 1)
    accesses = json.load(sys.stdin)
    refused = 0
    for a in accesses:
        why = refusal(od, a)
        if why is not None:
            refused += 1
            print("%s 0x%04X:%02X: %s" % (a["access"], a["index"], a["sub"], why))
    print("checked %d accesses" % len(accesses))
    return 1 if refused else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
