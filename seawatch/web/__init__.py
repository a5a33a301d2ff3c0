"""seawatch.web"""
