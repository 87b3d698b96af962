!> The text of one deck case checked as a whole before the compiler's
!> namelist reads take its groups: a namelist read takes the first &group
!> it finds and stops at its /, so what lies outside the groups, a group not
!> closed, a name given twice (the last value wins) or a word it reads by
!> its first letter (tomato: .true.) would otherwise pass silently.
!>
!> The syntax taken: groups &name ... / (not $name ... $end, nor &end);
!> assignments NAME = values or NAME(i) = values or NAME(i:j[:s]) = values,
!> the values separated by commas or blanks (two commas, or a comma after
!> =: a null value, which leaves its element as it was; r*: r null values),
!> each a number, r*number, r*'text', quoted text or a logical (T, F, true,
!> false, any case, with or without periods).
!>
!> The scan keeps what each assignment sets, element by element (a value or
!> a null), so that the group readers know what the deck gave without a
!> sentinel value (element_states), and where each group's text lies
!> (group_span_t), which is all its namelist read is given.
module mlid_deck_scan
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, itoa, line_t, utf8_head
  implicit none
  private
  public :: deck_scan, assignment_t, group_span_t, element_states, last_element, ABSENT, NULLED, GIVEN

  integer, parameter :: WORDLEN = 64
  !> What an assignment did to an element: nothing, a null value, a value.
  integer, parameter :: ABSENT = 0, NULLED = 1, GIVEN = 2
  !> Items (values and nulls) one assignment may hold: far beyond any
  !> list of a deck, short of an integer overflow or a mask too large.
  integer, parameter :: MAX_ITEMS = 10000000

  !> One assignment of a group: its group and name, the element its first
  !> item goes to and the step between items (first = -1 when the subscript
  !> is not of one dimension: the namelist read says what is wrong), the
  !> elements its subscript names (room, 0 when it has none or its upper
  !> bound is the array's), the items met (n), their runs (item, count,
  !> GIVEN or NULLED), its line and the longest quoted text among them (a
  !> namelist read cuts text to its variable's room without a word).
  type :: assignment_t
    character(len=WORDLEN) :: group = '', key = '', subscript = ''
    integer :: first = 1, step = 1, room = 0, n = 0, line = 0, longest = 0, nrun = 0
    integer, allocatable :: run(:, :)
  end type assignment_t

  !> Where a group's text lies: from lines(k1)(p1:) (its &) to
  !> lines(k2)(:p2) (its /); line, the deck line of its &.
  type :: group_span_t
    character(len=WORDLEN) :: name = ''
    integer :: line = 0, k1 = 0, p1 = 0, k2 = 0, p2 = 0
  end type group_span_t

  character(len=*), parameter :: BLANKS = ' '//achar(9)
  !> What the scan met last in an assignment's values (for null values)
  integer, parameter :: AFTER_EQUALS = 1, AFTER_VALUE = 2, AFTER_COMMA = 3
  !> The bytes of a name (and of a group's): these, and any byte of a
  !> non-ASCII character, so that a message quotes the whole of a name like
  !> ñx (not one cut at its first such byte); a namelist read then refuses it.
  character(len=*), parameter :: WORD_CHARS = &
    'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789'

contains

  !> Check a case's lines (comments stripped; the first is number line0)
  !> against the syntax above; groups: ' name name ... ', the groups known.
  !> status /= MLID_OK: msg is the first problem, naming its line.
  !> every: the assignments of all groups, in order; spans: the groups.
  subroutine deck_scan(lines, line0, groups, status, msg, every, spans)
    type(line_t), intent(in) :: lines(:)
    integer, intent(in) :: line0
    character(len=*), intent(in) :: groups
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(assignment_t), allocatable, intent(out) :: every(:)
    type(group_span_t), allocatable, intent(out) :: spans(:)
    character(len=:), allocatable :: seen, group, word
    integer :: k, p, e, ln, gline, after, ne, g0, ns
    logical :: ingroup, eq_next

    status = MLID_OK
    msg = ''
    seen = ' '
    group = ''
    word = ''
    gline = 0
    after = 0
    ne = 0               ! assignments so far: every(1:ne)
    g0 = 0               ! those of the groups before the one open
    ns = 0
    eq_next = .false.
    ingroup = .false.
    allocate (every(16), spans(8))
    do k = 1, size(lines)
      associate (s => lines(k)%s)
      ln = line0 + k - 1
      p = 1
      do
        p = next_char(s, p)
        if (p == 0) exit
        select case (s(p:p))
        case (',')
          if (.not. ingroup) call outside(s, p, ln)
          if (ne > g0) call null_value(every(ne))
          p = p + 1
        case ('/')
          if (.not. ingroup) call outside(s, p, ln)
          if (ingroup) then
            spans(ns)%k2 = k
            spans(ns)%p2 = p
            call ended()
          end if
          ingroup = .false.
          p = p + 1
        case ('&', '$')
          e = word_end(s, p + 1)
          word = utf8_head(s(p + 1:e - 1), WORDLEN + 1)
          if (s(p:p) == '$' .or. to_lower(word) == 'end') then
            call problem('line '//itoa(ln)//': '''//s(p:e - 1)//''': a group starts with '// &
                         '&name and ends with / ($name ... $end and &end are not read)')
          else if (ingroup) then
            call not_closed()
          else if (index(groups, ' '//to_lower(word)//' ') == 0 .or. len(word) == 0) then
            call problem('line '//itoa(ln)//': unknown group &'//shown(word)//' (groups are '// &
                         group_list(groups)//')')
          else if (index(seen, ' '//to_lower(word)//' ') > 0) then
            ! a compiler's namelist read would take the first and ignore the rest
            call problem('line '//itoa(ln)//': group &'//word//' given twice in one case')
          end if
          if (status /= MLID_OK) exit
          seen = seen//to_lower(word)//' '
          group = word
          gline = ln
          ingroup = .true.
          g0 = ne
          call open_span(to_lower(word), ln, k, p)
          p = e
        case ('=')           ! the = of a name that ends the line before
          if (.not. (ingroup .and. eq_next)) then
            if (.not. ingroup) call outside(s, p, ln)
            if (ingroup) call problem('line '//itoa(ln)//': '''//shown(s(p:))// &
                                      ''' in group &'//group//' is no NAME = value')
          end if
          eq_next = .false.
          p = p + 1
        case ('''', '"')
          if (.not. ingroup) call outside(s, p, ln)
          if (status == MLID_OK) call value(s, p, ln)
        case default
          if (.not. ingroup) call outside(s, p, ln)
          if (status == MLID_OK) call name_or_value(s, p, ln)
        end select
        if (status /= MLID_OK) exit
      end do
      end associate
      if (status /= MLID_OK) exit
    end do
    if (status == MLID_OK .and. ingroup) call not_closed()
    every = every(1:ne)
    spans = spans(1:ns)

  contains

    subroutine problem(text)
      character(len=*), intent(in) :: text
      status = MLID_ERR_INPUT
      msg = text
    end subroutine problem

    subroutine not_closed()
      call problem('group &'//group//' at line '//itoa(gline)//' is not closed with /')
    end subroutine not_closed

    !> Text where no group is open.
    subroutine outside(s, p, ln)
      character(len=*), intent(in) :: s
      integer, intent(in) :: p, ln
      call problem('line '//itoa(ln)//': '''//shown(s(p:))//''' is outside any group (a '// &
                   'group is &name ... /, a comment starts with !)')
    end subroutine outside

    !> A group starts: its name and where its & is.
    subroutine open_span(name, ln, k, p)
      character(len=*), intent(in) :: name
      integer, intent(in) :: ln, k, p
      type(group_span_t), allocatable :: more(:)
      if (ns == size(spans)) then
        allocate (more(2*ns))
        more(1:ns) = spans
        call move_alloc(more, spans)
      end if
      ns = ns + 1
      spans(ns) = group_span_t(name=name, line=ln, k1=k, p1=p)
    end subroutine open_span

    !> The assignment a after the others (every grown by doubling: a deck
    !> may hold many).
    subroutine push(a)
      type(assignment_t), intent(in) :: a
      type(assignment_t), allocatable :: more(:)
      integer :: j
      if (ne == size(every)) then
        allocate (more(2*ne))
        do j = 1, ne
          call move_assignment(every(j), more(j))
        end do
        call move_alloc(more, every)
      end if
      ne = ne + 1
      every(ne) = a
    end subroutine push

    !> At p, a name (NAME, NAME(...), then =: an assignment) or a value.
    subroutine name_or_value(s, p, ln)
      character(len=*), intent(in) :: s
      integer, intent(inout) :: p
      integer, intent(in) :: ln
      type(assignment_t) :: a
      character(len=:), allocatable :: why
      integer :: e, q, j
      e = word_end(s, p)
      q = next_char(s, e)
      a%key = to_lower(s(p:min(e - 1, p + WORDLEN - 1)))
      if (e > p .and. q > 0) then
        if (s(q:q) == '(') then
          j = index(s(q:min(len(s), q + WORDLEN)), ')')
          if (j > 0) then
            a%subscript = s(q + 1:q + j - 2)
            q = next_char(s, q + j)
          end if
        end if
      end if
      if (e > p .and. q == 0) eq_next = equals_next(k)
      if (e == p .or. (q == 0 .and. .not. eq_next)) then
        call value(s, p, ln)
        return
      end if
      if (q > 0) then
        if (s(q:q) /= '=') then
          call value(s, p, ln)
          return
        end if
      end if
      if (e - p > WORDLEN) then
        call problem('line '//itoa(ln)//': unknown name '//shown(s(p:e - 1))//' in group &'// &
                     group)
        return
      end if
      a%line = ln
      a%group = to_lower(group)
      call ended()                       ! the assignment before ends here
      if (status /= MLID_OK) return
      call elements(a, why)
      if (len(why) > 0) then
        call problem('line '//itoa(ln)//': '//trim(a%key)//'('//trim(a%subscript)//'): '//why)
        return
      end if
      call push(a)
      after = AFTER_EQUALS
      p = len(s) + 1                     ! the = on the next line: eq_next
      if (q > 0) p = q + 1
    end subroutine name_or_value

    !> The assignment just ended (every(ne), at the next name or the
    !> group's /): no more items than the elements its subscript names
    !> (a namelist read would take the one too many for a name), and none
    !> an earlier one of its name in its group set (check_twice).
    subroutine ended()
      if (ne <= g0) return
      associate (a => every(ne))
        if (a%room > 0 .and. a%n > a%room) then
          call problem('line '//itoa(a%line)//': '//trim(a%key)//trim(paren(a%subscript))// &
                       ' has '//itoa(a%n)//' values for its '//itoa(a%room)//' element'// &
                       trim(merge('s', ' ', a%room > 1))//' in group &'//group)
          return
        end if
      end associate
      call check_twice()
    end subroutine ended

    !> The assignment just ended may set no element that an earlier one of
    !> its name in its group set.
    subroutine check_twice()
      integer :: j
      if (ne <= g0) return
      associate (a => every(ne))
        do j = g0 + 1, ne - 1
          if (every(j)%key /= a%key) cycle
          if (overlap(every(j), a)) then
            call problem('line '//itoa(a%line)//': '//trim(a%key)//trim(paren(a%subscript))// &
                         ' given twice in group &'//group//' (first at line '// &
                         itoa(every(j)%line)//')')
            return
          end if
        end do
      end associate
    end subroutine check_twice

    !> Whether the first text after line kl opens with = (a name ending
    !> its line, its = on the next).
    logical function equals_next(kl)
      integer, intent(in) :: kl
      integer :: j, c
      equals_next = .false.
      do j = kl + 1, size(lines)
        c = next_char(lines(j)%s, 1)
        if (c == 0) cycle
        equals_next = lines(j)%s(c:c) == '='
        return
      end do
    end function equals_next

    !> A comma: after = or after another comma it stands for a null value,
    !> an item that keeps its element as it was.
    subroutine null_value(a)
      type(assignment_t), intent(inout) :: a
      if (after == AFTER_EQUALS .or. after == AFTER_COMMA) call add_items(a, 1, NULLED)
      after = AFTER_COMMA
    end subroutine null_value

    !> count items of kind (GIVEN or NULLED) after the assignment's others.
    subroutine add_items(a, count, kind)
      type(assignment_t), intent(inout) :: a
      integer, intent(in) :: count, kind
      integer, allocatable :: more(:, :)
      if (count > MAX_ITEMS - a%n) then
        call problem('line '//itoa(a%line)//': '//trim(a%key)//' in group &'//group// &
                     ' is given over '//itoa(MAX_ITEMS)//' values')
        return
      end if
      a%n = a%n + count
      if (a%nrun > 0) then
        if (a%run(3, a%nrun) == kind) then
          a%run(2, a%nrun) = a%run(2, a%nrun) + count
          return
        end if
      end if
      if (.not. allocated(a%run)) allocate (a%run(3, 4))
      if (a%nrun == size(a%run, 2)) then
        allocate (more(3, 2*a%nrun))
        more(:, 1:a%nrun) = a%run
        call move_alloc(more, a%run)
      end if
      a%nrun = a%nrun + 1
      a%run(:, a%nrun) = [a%n - count + 1, count, kind]
    end subroutine add_items

    !> A value at p (quoted text, or an unquoted word up to a blank, a comma
    !> or /), counted to the last assignment; p moves past it.
    subroutine value(s, p, ln)
      character(len=*), intent(in) :: s
      integer, intent(inout) :: p
      integer, intent(in) :: ln
      integer :: e, n
      logical :: null
      n = 1
      null = .false.
      e = verify(s(p:min(len(s), p + 12)), '0123456789')   ! r*'text': r copies of the text
      if (e > 1) then
        e = p + e - 1
        if (s(e:e) == '*' .and. e < len(s)) then
          if (scan(s(e + 1:e + 1), '''"') == 1) then
            read (s(p:e - 1), *) n
            p = e + 1
          end if
        end if
      end if
      if (s(p:p) == '''' .or. s(p:p) == '"') then
        e = quote_end(s, p)
        if (e == 0) then
          call problem('line '//itoa(ln)//': the quote of '//shown(s(p:))// &
                       ' is not closed on its line')
          return
        end if
        if (ne > g0) every(ne)%longest = max(every(ne)%longest, text_length(s(p:e)))
        e = e + 1
      else
        e = scan(s(p:), BLANKS//',/''"')
        if (e == 0) then
          e = len(s) + 1
        else
          e = p + e - 1
        end if
        if (.not. plain_value(s(p:e - 1), n, null)) then
          if (ne == g0) then
            call problem('line '//itoa(ln)//': '''//shown(s(p:))//''' in group &'//group// &
                         ' is no NAME = value')
          else
            call problem('line '//itoa(ln)//': bad value '//shown(s(p:e - 1))//' for '// &
                         trim(every(ne)%key)//' in group &'//group//': not a '// &
                         'number, not quoted text and not a logical (.true., .false., T, F, '// &
                         'true or false, with or without periods)')
          end if
          return
        end if
      end if
      if (ne == g0) then
        call problem('line '//itoa(ln)//': '''//shown(s(p:))//''' in group &'//group// &
                     ' is no NAME = value')
        return
      end if
      call add_items(every(ne), n, merge(NULLED, GIVEN, null))
      after = AFTER_VALUE
      p = e
    end subroutine value

  end subroutine deck_scan

  !> b takes what a holds (its runs moved, not copied).
  subroutine move_assignment(a, b)
    type(assignment_t), intent(inout) :: a
    type(assignment_t), intent(out) :: b
    b%group = a%group
    b%key = a%key
    b%subscript = a%subscript
    b%first = a%first
    b%step = a%step
    b%room = a%room
    b%n = a%n
    b%line = a%line
    b%longest = a%longest
    b%nrun = a%nrun
    if (allocated(a%run)) call move_alloc(a%run, b%run)
  end subroutine move_assignment

  !> The last element the assignments of key in group set (a value or a
  !> null), 0 for none.
  integer function last_element(every, group, key)
    type(assignment_t), intent(in) :: every(:)
    character(len=*), intent(in) :: group, key
    integer :: k, r
    last_element = 0
    do k = 1, size(every)
      associate (a => every(k))
        if (a%group /= group .or. a%key /= key .or. a%first < 0) cycle
        do r = 1, a%nrun
          last_element = max(last_element, a%first + (a%run(1, r) - 1)*a%step, &
                             a%first + (a%run(1, r) + a%run(2, r) - 2)*a%step)
        end do
      end associate
    end do
  end function last_element

  !> What the assignments of key in group did to elements 1 to n: ABSENT,
  !> NULLED or GIVEN (a value wins over a null, whichever came first).
  function element_states(every, group, key, n) result(st)
    type(assignment_t), intent(in) :: every(:)
    character(len=*), intent(in) :: group, key
    integer, intent(in) :: n
    integer :: st(n)
    integer :: k, r, j, e
    st = ABSENT
    do k = 1, size(every)
      associate (a => every(k))
        if (a%group /= group .or. a%key /= key .or. a%first < 0) cycle
        do r = 1, a%nrun
          do j = a%run(1, r), a%run(1, r) + a%run(2, r) - 1
            e = a%first + (j - 1)*a%step
            if ((a%step > 0 .and. e > n) .or. (a%step < 0 .and. e < 1)) exit
            if (e >= 1 .and. e <= n) st(e) = max(st(e), a%run(3, r))
          end do
        end do
      end associate
    end do
  end function element_states

  !> The length of quoted text (its quotes off, a doubled quote one).
  integer function text_length(quoted)
    character(len=*), intent(in) :: quoted
    integer :: k
    text_length = 0
    k = 2
    do while (k < len(quoted))
      text_length = text_length + 1
      if (quoted(k:k) == quoted(1:1)) k = k + 1
      k = k + 1
    end do
  end function text_length

  !> Where an assignment's items go, from its subscript: (i), (i:j) or
  !> (i:j:s), a bound left out being the array's (only the lower, 1, is
  !> known here), or none; and how many elements a section names (room,
  !> when its bounds are given).  why: what is wrong with a section ('' if nothing):
  !> a stride of 0, or one that does not go from i to j.
  subroutine elements(a, why)
    type(assignment_t), intent(inout) :: a
    character(len=:), allocatable, intent(out) :: why
    character(len=WORDLEN) :: part(3)
    integer :: c1, c2, lo, hi, step, ios
    why = ''
    a%first = 1
    a%step = 1
    a%room = 0
    if (len_trim(a%subscript) == 0) return
    a%first = -1             ! not one dimension, or not known here: the namelist read says
    if (index(a%subscript, ',') > 0) return
    part = ''
    c1 = index(a%subscript, ':')
    if (c1 == 0) then
      part(1) = a%subscript
    else
      part(1) = a%subscript(1:c1 - 1)
      c2 = index(a%subscript(c1 + 1:), ':')
      if (c2 == 0) then
        part(2) = a%subscript(c1 + 1:)
      else
        part(2) = a%subscript(c1 + 1:c1 + c2 - 1)
        part(3) = a%subscript(c1 + c2 + 1:)
      end if
    end if
    lo = 1
    hi = 1
    step = 1
    ios = 0
    if (len_trim(part(1)) > 0) read (part(1), *, iostat=ios) lo
    if (ios == 0 .and. len_trim(part(2)) > 0) read (part(2), *, iostat=ios) hi
    if (ios == 0 .and. len_trim(part(3)) > 0) read (part(3), *, iostat=ios) step
    if (ios /= 0 .or. (c1 == 0 .and. len_trim(part(1)) == 0)) return
    if (step == 0) then
      why = 'the stride is 0 (NAME(i:j:s) takes every s-th element from i to j)'
      return
    end if
    if (step < 0 .and. len_trim(part(1)) == 0) return   ! from the array's upper bound
    ! (i) = a, b, ... fills the elements from i on (as a compiler reads it);
    ! (i:) runs to the array's upper bound: only (i:j[:s]) has a room here
    if (c1 > 0 .and. len_trim(part(2)) > 0) then
      if ((step > 0 .and. hi < lo) .or. (step < 0 .and. hi > lo)) then
        why = 'a stride of '//itoa(step)//' does not go from '//itoa(lo)//' to '//itoa(hi)// &
              ' (NAME(i:j:s) takes every s-th element from i to j)'
        return
      end if
      a%room = int(min((int(hi, int64) - lo)/step + 1, int(huge(1), int64)))
    end if
    a%first = lo
    a%step = step
  end subroutine elements

  !> Whether two assignments of one name set a common element by a value.
  logical function overlap(a, b)
    type(assignment_t), intent(in) :: a, b
    logical, allocatable :: set(:)
    integer, allocatable :: ea(:), eb(:)
    if (a%first < 0 .or. b%first < 0) then
      overlap = a%subscript == b%subscript
      return
    end if
    ea = given_elements(a)
    eb = given_elements(b)
    overlap = .false.
    if (size(ea) == 0 .or. size(eb) == 0) return
    allocate (set(min(minval(ea), minval(eb)):max(maxval(ea), maxval(eb))))
    set = .false.
    set(ea) = .true.
    overlap = any(set(eb))
  end function overlap

  !> The elements an assignment gives a value, within 1 to MAX_ITEMS (the
  !> namelist read refuses the others).
  function given_elements(a) result(el)
    type(assignment_t), intent(in) :: a
    integer, allocatable :: el(:)
    integer :: r, j, m, e
    allocate (el(0))
    m = 0
    do r = 1, a%nrun
      if (a%run(3, r) == GIVEN) m = m + a%run(2, r)
    end do
    deallocate (el)
    allocate (el(m))
    m = 0
    do r = 1, a%nrun
      if (a%run(3, r) /= GIVEN) cycle
      do j = a%run(1, r), a%run(1, r) + a%run(2, r) - 1
        e = a%first + (j - 1)*a%step
        if (e < 1 .or. e > MAX_ITEMS) cycle
        m = m + 1
        el(m) = e
      end do
    end do
    el = el(1:m)
  end function given_elements

  !> An unquoted value: a number, r*number, r* (r null values: null), a
  !> logical, nan or inf (the finite checks are the readers'); n, the
  !> values it stands for.
  logical function plain_value(w, n, null)
    character(len=*), intent(in) :: w
    integer, intent(out) :: n
    logical, intent(out) :: null
    integer :: star, ios, v
    n = 1
    null = .false.
    v = 1
    star = index(w, '*')
    if (star > 1) then
      plain_value = star <= 10 .and. verify(w(1:star - 1), '0123456789') == 0
      if (.not. plain_value) return
      read (w(1:star - 1), '(i9)', iostat=ios) n
      plain_value = ios == 0 .and. n > 0
      if (.not. plain_value) return
      v = star + 1
      null = v > len(w)
      if (null) return
    end if
    associate (x => w(v:))
      plain_value = is_number(x) .or. is_logical(x)
      if (.not. plain_value .and. len(x) <= 9) plain_value = any(to_lower(x) == &
        [character(len=9) :: 'nan', 'inf', '+inf', '-inf', 'infinity', '+infinity', '-infinity'])
    end associate
  end function plain_value

  !> A logical as Fortran writes one: t, f, true or false, any case, with
  !> or without a period before and after (.t., .false, T.): not any word
  !> that starts with t or f, as the namelist read would take it.
  logical function is_logical(w)
    character(len=*), intent(in) :: w
    integer :: a, b
    a = 1
    b = len(w)
    if (b > 0) then
      if (w(1:1) == '.') a = 2
    end if
    if (b >= a) then
      if (w(b:b) == '.') b = b - 1
    end if
    is_logical = .false.
    if (b - a < 5) is_logical = any(to_lower(w(a:b)) == [character(len=5) :: 't', 'f', 'true', &
                                                         'false'])
  end function is_logical

  !> [sign] digits [. digits] [e|d [sign] digits], at least one digit.
  logical function is_number(w)
    character(len=*), intent(in) :: w
    integer :: p, nd
    is_number = .false.
    p = 1
    nd = 0
    if (len(w) == 0) return
    if (scan(w(1:1), '+-') == 1) p = 2
    call digits()
    if (p <= len(w)) then
      if (w(p:p) == '.') then
        p = p + 1
        call digits()
      end if
    end if
    if (nd == 0) return
    if (p <= len(w)) then
      if (scan(w(p:p), 'eEdD') /= 1) return
      p = p + 1
      if (p <= len(w)) then
        if (scan(w(p:p), '+-') == 1) p = p + 1
      end if
      nd = 0
      call digits()
      if (nd == 0) return
    end if
    is_number = p > len(w)
  contains
    subroutine digits()
      do while (p <= len(w))
        if (scan(w(p:p), '0123456789') /= 1) exit
        p = p + 1
        nd = nd + 1
      end do
    end subroutine digits
  end function is_number

  !> The first character at or after p that is not blank (0: none).
  integer function next_char(s, p)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    if (p > len(s)) then
      next_char = 0
      return
    end if
    next_char = verify(s(p:), BLANKS)
    if (next_char > 0) next_char = p + next_char - 1
  end function next_char

  !> Where the word (letters, digits, _, non-ASCII bytes) starting at p
  !> ends (one after it).
  integer function word_end(s, p)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    integer :: k
    word_end = len(s) + 1
    do k = p, len(s)
      if (iachar(s(k:k)) < 128 .and. index(WORD_CHARS, s(k:k)) == 0) then
        word_end = k
        return
      end if
    end do
  end function word_end

  !> The closing quote of the text quoted at p (a doubled quote is one
  !> quote of the text); 0 when the line ends first.
  integer function quote_end(s, p)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    integer :: k
    quote_end = 0
    k = p + 1
    do while (k <= len(s))
      if (s(k:k) == s(p:p)) then
        if (k < len(s)) then
          if (s(k + 1:k + 1) == s(p:p)) then
            k = k + 2
            cycle
          end if
        end if
        quote_end = k
        return
      end if
      k = k + 1
    end do
  end function quote_end

  !> Text for a message: trimmed, at most 40 bytes (never cut inside a
  !> UTF-8 character).
  function shown(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    t = trim(s)
    if (len(t) > 40) t = utf8_head(t, 37)//'...'
  end function shown

  function paren(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    t = ''
    if (len_trim(s) > 0) t = '('//trim(s)//')'
  end function paren

  !> ' case model ... ' -> '&case, &model, ...'
  function group_list(groups) result(t)
    character(len=*), intent(in) :: groups
    character(len=:), allocatable :: t
    integer :: p, e
    t = ''
    p = next_char(groups, 1)
    do while (p > 0)
      e = index(groups(p:), ' ') + p - 1
      if (len(t) > 0) t = t//', '
      t = t//'&'//groups(p:e - 1)
      p = next_char(groups, e)
    end do
  end function group_list

end module mlid_deck_scan
