"""seawatch.fuse"""
