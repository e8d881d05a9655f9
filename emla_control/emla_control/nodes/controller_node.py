"""The controller node (arrives with issue #4)."""
import sys


def main():
    print('controller: this node arrives with issue #4 and is not available yet', file=sys.stderr)
    return 3


if __name__ == '__main__':
    sys.exit(main())
