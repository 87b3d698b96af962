!> Affine ties written as text, the same for the deck and for Python:
!>   'a = b'                          a held equal to b
!>   'a = c + s*b'                    a = c + s b (s*b or b*s, c anywhere)
!>   'g(3,1) = 104.67*g(1,1) - f(1,1) + 0.5'   a sum of such terms
!> Names are element names of the model's layout ('f(1,2)', 'cl(3)').
module mlid_ties
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_layout, only: layout_table_t, element_index
  implicit none
  private
  public :: tie_parse, MAXTERM

  integer, parameter :: MAXTERM = 16

contains

  !> The tied entry (to), its constant (offset) and its terms (n, from, scale).
  subroutine tie_parse(lt, text, to, offset, n, from, scale, status, msg)
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: text
    integer, intent(out) :: to, n, from(MAXTERM)
    real(wp), intent(out) :: offset, scale(MAXTERM)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: eq, p, name
    real(wp) :: sgn, factor

    to = 0
    n = 0
    offset = 0.0_wp
    from = 0
    scale = 0.0_wp
    status = MLID_ERR_INPUT
    eq = index(text, '=')
    if (eq == 0) then
      msg = 'tie '''//trim(text)//''' must read ''a = b'' or ''a = c + s*b + ...'''
      return
    end if
    to = element_index(lt, text(1:eq - 1))
    if (to == 0) then
      msg = 'tie '''//trim(text)//''': '''//trim(adjustl(text(1:eq - 1)))//''' is no parameter'
      return
    end if
    p = eq + 1
    sgn = 1.0_wp
    if (.not. next_sign(.true.)) return
    do
      if (.not. term(factor, name)) return
      if (name == 0) then
        offset = offset + sgn*factor
      else if (n == MAXTERM) then
        write (msg, '(a,i0,a)') 'tie '''//trim(text)//''' has more than ', MAXTERM, ' terms'
        return
      else
        n = n + 1
        from(n) = name
        scale(n) = sgn*factor
      end if
      call skip()
      if (p > len_trim(text)) exit
      if (.not. next_sign(.false.)) return
    end do
    if (n == 0) then
      msg = 'tie '''//trim(text)//''' names no parameter to follow (a constant is a fixed value)'
      return
    end if
    if (any(from(1:n) == to)) then
      msg = 'tie '''//trim(text)//''' ties a parameter to itself'
      return
    end if
    if (.not. (ieee_is_finite(offset) .and. all(ieee_is_finite(scale(1:n))))) then
      msg = 'tie '''//trim(text)//''' has a number that is not finite'
      return
    end if
    status = MLID_OK
    msg = ''

  contains

    subroutine skip()
      do while (p <= len(text))
        if (text(p:p) /= ' ') exit
        p = p + 1
      end do
    end subroutine skip

    !> The sign before a term: '+' or '-' (optional before the first).
    logical function next_sign(first) result(ok)
      logical, intent(in) :: first
      call skip()
      sgn = 1.0_wp
      ok = .true.
      if (p <= len(text)) then
        if (text(p:p) == '+' .or. text(p:p) == '-') then
          if (text(p:p) == '-') sgn = -1.0_wp
          p = p + 1
          return
        end if
      end if
      if (first) return
      ok = .false.
      write (msg, '(a,i0)') 'tie '''//trim(text)//''': expected + or - at character ', p
    end function next_sign

    !> A product of numbers and at most one parameter name.
    logical function term(factor, name) result(ok)
      real(wp), intent(out) :: factor
      integer, intent(out) :: name
      real(wp) :: value
      integer :: item
      factor = 1.0_wp
      name = 0
      do
        ok = atom(value, item)
        if (.not. ok) return
        if (item > 0) then
          if (name > 0) then
            ok = .false.
            msg = 'tie '''//trim(text)//''': a term multiplies two parameters (ties are affine)'
            return
          end if
          name = item
        else
          factor = factor*value
        end if
        call skip()
        if (p > len(text)) exit
        if (text(p:p) /= '*') exit
        p = p + 1
      end do
    end function term

    !> A number (item = 0, its value) or an element name (item its index).
    logical function atom(value, item) result(ok)
      real(wp), intent(out) :: value
      integer, intent(out) :: item
      character(len=*), parameter :: WORD = 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ'// &
                                            '0123456789_.'
      integer :: start, close, ios, after
      call skip()
      start = p
      value = 0.0_wp
      item = 0
      ok = .false.
      if (p > len_trim(text)) then
        msg = 'tie '''//trim(text)//''' ends where a term should follow'
        return
      end if
      if (verify(text(p:p), 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ') == 0) then
        ! a bare name (an equations model's own), key(i) / key(i,j), or a table's NAME[i,j]
        close = verify(text(p:)//' ', WORD) - 1
        after = p + close
        if (after <= len(text)) after = after - 1 + verify(text(after:)//'x', ' ')
        if (after <= len(text)) then
          if (text(after:after) == '(') close = index(text(p:), ')')
          if (text(after:after) == '[') close = index(text(p:), ']')   ! a table value
        end if
        if (close == 0) then
          write (msg, '(a,i0)') 'tie '''//trim(text)//''': a parameter name needs (i) or '// &
            '(i,j) at character ', p
          return
        end if
        item = element_index(lt, text(p:p + close - 1))
        if (item == 0) then
          msg = 'tie '''//trim(text)//''': '''//text(p:p + close - 1)//''' is no parameter'
          return
        end if
        p = p + close
      else
        do while (p <= len(text))
          if (verify(text(p:p), '0123456789.') /= 0) then
            if (.not. ((text(p:p) == 'e' .or. text(p:p) == 'E' .or. text(p:p) == 'd' .or. &
                        text(p:p) == 'D') .or. ((text(p:p) == '+' .or. text(p:p) == '-') &
                        .and. p > start .and. scan(text(max(p - 1, 1):max(p - 1, 1)), &
                        'eEdD') == 1))) exit
          end if
          p = p + 1
        end do
        read (text(start:p - 1), *, iostat=ios) value
        if (ios /= 0 .or. p == start) then
          write (msg, '(a,i0)') 'tie '''//trim(text)//''': expected a number or a parameter '// &
            'at character ', start
          return
        end if
      end if
      ok = .true.
    end function atom

  end subroutine tie_parse

end module mlid_ties
