"""``eigmotion serve``: the query as a web page on localhost, and its HTTP API."""
